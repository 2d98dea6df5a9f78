"""The workbench calibration set's generator (benchmarks/workbench_calibration.py): a dataset is a function of its
seed, and what it writes is read by the project's CSV reader. One short test (one load, a 1 cm stop) keeps it cheap."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))

import workbench_calibration as calib

from triplanar.labdata import write_lab_data
from triplanar.measurement import read_measurements


def _small(label: str, seed: int) -> dict:
    """The dataset's settings, cut to one test at the highest load stopped after about 1 cm (cheap)."""
    return {**calib.settings(label, seed), "loads_N": [55.6], "repeats": [1], "stop_range_m": [0.01, 0.012]}


def test_a_dataset_is_a_function_of_its_seed_and_reads_back(tmp_path: Path) -> None:
    assert calib.settings("tip_offset", 1003) == calib.settings("tip_offset", 1003)
    assert calib.settings("tip_offset", 1003) != calib.settings("tip_offset", 1004)
    tuning = {seed for _, seed in calib.datasets("tuning")}
    assert not tuning & {seed for _, seed in calib.datasets("held-out")}      # the parts share no seed
    cfg = _small("time_offset", 1011)
    first, test = calib.one_test((cfg, 55.6, 1))
    again, test2 = calib.one_test((cfg, 55.6, 1))
    assert first == {**again, "cpu_s": first["cpu_s"]} and first["status"] == "travel"
    np.testing.assert_array_equal(test.positions, test2.positions)
    np.testing.assert_array_equal(test.t_s, test2.t_s)
    other, _ = calib.one_test((_small("time_offset", 1012), 55.6, 1))
    assert other["stop_travel_m"] != first["stop_travel_m"]
    # the clock starts dt late (time_offset), the samples are 5 ms apart as recorded
    dt = cfg["truth"][0][1]["dt_s"]
    assert abs(test.t_s[0] - dt) < 1e-12 and np.allclose(np.diff(test.t_s), 0.005)
    path, truth_path = write_lab_data(tmp_path / "d.csv", [test], {"settings": cfg})
    back = read_measurements(path)
    assert len(back) == 1 and back[0].test_id == "F55.6N-r1" and back[0].shear_force_N == 55.6
    np.testing.assert_allclose(back[0].positions, test.positions, rtol=0, atol=1e-12)
    assert json.loads(truth_path.read_text())["settings"]["seed"] == 1011


def test_the_beyond_part_moves_the_true_block_and_the_clock_and_leaves_the_other_parts_as_they_were() -> None:
    """Issue 33's kinds (a number off its drawing, a fast logger clock) have their own mix: a full range's first
    datasets are the labels they were before those kinds existed (seeds 4000-4065's truths were written then)."""
    assert calib.datasets("tuning", 4000)[:6] == [("end_friction", 4000), ("refit_end_friction_4", 4001),
                                              ("pair_end_friction_tip_offset", 4002), ("clean_case_b", 4003),
                                              ("outside_viscous_drag", 4004), ("rate_friction", 4005)]
    beyond = calib.datasets("beyond-tuning")
    assert {label for label, _ in beyond} == set(calib.BEYOND_LABELS) and len(beyond) == 18 + 36 + 36 + 36
    assert set(beyond) <= set(calib.datasets("tuning"))         # each reported once: they tune since
    assert not {label for label, seed in calib.datasets("tuning") if seed // 100 not in (60, 61, 62, 63)} & set(
        calib.BEYOND_LABELS)
    second = calib.datasets("beyond-2")
    assert len(second) == 36 and [s for _, s in second] == list(range(6100, 6136))
    assert {label for label, _ in second} == set(calib.BEYOND_LABELS)
    assert not {s for _, s in calib.datasets("beyond-5") + calib.datasets("held-out")} & {
        s for _, s in calib.datasets("tuning")}
    assert set(calib.REPORTING) == {"beyond-5", "held-out"}
    cfg = _small("given_cp2_x1", 6005)
    (name, moved), = cfg["truth"]
    drawn = calib.one_test(({**cfg, "truth": []}, 55.6, 1))[1].positions[0]
    record, test = calib.one_test((cfg, 55.6, 1))
    assert name == "specimen" and record["status"] == "travel"
    shift = moved["cp2_x1_m"] - calib.reference()[0].contact_points_m[1][0]
    assert 0.002 <= abs(shift) <= 0.004
    # the rangefinders see the true block: CP2 starts where the true pad is (within the noise), not the drawn one
    assert abs((test.positions[0, 1, 0] - drawn[1, 0]) - shift) < 5 * cfg["noise_m"] + 2e-4
    clock = _small("outside_clock_rate", 6001)
    _, fast = calib.one_test((clock, 55.6, 1))
    assert np.allclose(np.diff(fast.t_s), 0.005 * clock["clock_rate"])
