"""Tests of the stand-in laboratory (triplanar/labdata.py) and ``triplanar lab-data``."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from triplanar import MeasurementError, PAPER_LOADS_N, make_effect, paper_model, read_measurements, reference, simulate
from triplanar import labdata
from triplanar.cli import main
from triplanar.labdata import foundation_plan_box, generate_lab_data, hermite_in_time, write_lab_data
from triplanar.measurement import MeasuredTest

REST = reference()[0].contact_points_m
SMALL = dict(loads=(32.5, 55.6), repeats=2)


@pytest.fixture(scope="module")
def full() -> tuple[list[MeasuredTest], dict]:
    return generate_lab_data()


@pytest.fixture(scope="module")
def full_clean() -> tuple[list[MeasuredTest], dict]:
    return generate_lab_data(noise_m=0.0)


def _same(a: list[MeasuredTest], b: list[MeasuredTest]) -> bool:
    return len(a) == len(b) and all(x.test_id == y.test_id and np.array_equal(x.positions, y.positions)
                                    and np.array_equal(x.t_s, y.t_s) for x, y in zip(a, b))


def test_default_dataset_shape(full):
    tests, truth = full
    assert len(tests) == 48 and not truth["skipped"]
    assert sorted({t.shear_force_N for t in tests}) == sorted(PAPER_LOADS_N)
    assert [e["spec"] for e in truth["effects"]] == ["end_friction:phi_deg=8"]
    assert truth["seed"] == 0 and truth["noise_m"] == 2e-4 and truth["rate_hz"] == 200.0
    for test, record in zip(tests, truth["tests"]):
        assert record["test_id"] == test.test_id
        # sampled at exactly k / rate from the start of sliding
        np.testing.assert_array_equal(test.t_s, np.arange(test.n_samples) / 200.0)
        # manual termination: stopped at the drawn travel, drawn from [5, 8] cm
        assert 0.05 <= record["stop_travel_m"] <= 0.08
        assert record["status"] == "travel"
        assert record["final_travel_m"] <= record["stop_travel_m"]
        assert record["stop_travel_m"] - record["final_travel_m"] < 1.0 / 200.0 * 1.1  # < one interval at < 1.1 m/s


def test_deterministic_for_a_seed_and_different_across_seeds():
    a, ta = generate_lab_data(**SMALL, seed=7)
    b, tb = generate_lab_data(**SMALL, seed=7)
    c, _ = generate_lab_data(**SMALL, seed=8)
    assert _same(a, b) and ta == tb
    assert not _same(a, c)


def test_a_test_does_not_depend_on_the_other_loads():
    alone, _ = generate_lab_data(loads=(32.5,), repeats=2, seed=3)
    together, _ = generate_lab_data(loads=(27.8, 32.5), repeats=2, seed=3)
    assert _same(alone, [t for t in together if t.shear_force_N == 32.5])


def test_noise_statistics_match_the_setting(full, full_clean):
    noisy, _ = full
    clean, _ = full_clean
    # The noise is drawn last, so the noise-free run has the same samples: the difference is the noise.
    assert [t.n_samples for t in noisy] == [t.n_samples for t in clean]
    noise = np.concatenate([(a.positions - b.positions).ravel() for a, b in zip(noisy, clean)])
    assert noise.size > 20_000
    assert abs(noise.mean()) < 4 * 2e-4 / np.sqrt(noise.size)
    assert abs(noise.std() / 2e-4 - 1) < 0.10
    # independent per coordinate: x1, x2, x3 noise uncorrelated
    per_coord = np.concatenate([(a.positions - b.positions).reshape(-1, 3) for a, b in zip(noisy, clean)])
    corr = np.corrcoef(per_coord.T)
    assert np.abs(corr - np.eye(3)).max() < 0.05


def test_noise_follows_a_larger_setting():
    noisy, _ = generate_lab_data(**SMALL, noise_m=1e-3)
    clean, _ = generate_lab_data(**SMALL, noise_m=0.0)
    noise = np.concatenate([(a.positions - b.positions).ravel() for a, b in zip(noisy, clean)])
    assert abs(noise.std() / 1e-3 - 1) < 0.10


def test_no_sample_beyond_the_foundation_block(full):
    tests, truth = full
    box = foundation_plan_box(reference()[0])
    assert (box.x1_max - box.x1_min, box.x3_max - box.x3_min) == pytest.approx((0.30, 0.45))
    for test in tests:
        assert box.contains(test.positions).all(), test.test_id
    assert truth["foundation_plan_m"] == box.as_dict()


def test_a_test_running_off_the_block_is_cut(monkeypatch):
    monkeypatch.setattr(labdata, "FOUNDATION_PLAN_M", (0.20, 0.45))  # front edge at x1 = 0.05 m
    tests, truth = generate_lab_data(loads=(45.0,), repeats=1)
    record = truth["tests"][0]
    assert record["cut_at_foundation_edge"] is True
    assert tests[0].positions[:, :, 0].max() <= 0.05
    assert record["final_travel_m"] < 0.05  # CP2 and CP3 start at x1 = 0


def test_interpolation_matches_the_integrator():
    model = paper_model("B", 55.6)  # the coarsest steps of the default set
    full = simulate(model)
    for travel in (0.013, 0.041, 0.067):
        short = simulate(model, travel_m=travel)
        p = hermite_in_time(full, np.array([short.t[-1]]))[0]
        assert np.abs(p - short.contact_points[-1]).max() < 1e-8


def test_truth_reproduces_the_data(full_clean):
    """Rebuilding a test's physics from its truth record gives the noise-free samples back."""
    tests, truth = full_clean
    for i in (0, 25, 47):
        test, rec = tests[i], truth["tests"][i]
        phis = ",".join(f"phi{k + 1}_deg={v!r}" for k, v in enumerate(rec["friction_deg"]))
        model = paper_model("B", rec["shear_force_N"], effects=[
            make_effect(f"end_friction:phi_deg={rec['tip_friction_deg']!r}"), make_effect(f"contact_friction:{phis}")])
        result = simulate(model, travel_m=rec["stop_travel_m"])
        np.testing.assert_allclose(hermite_in_time(result, test.t_s), test.positions, atol=1e-12)


def test_scatter_statistics(full):
    _, truth = full
    nominal = np.array([17.0, 14.0, 11.0, 8.0])
    drawn = np.array([r["friction_deg"] + [r["tip_friction_deg"]] for r in truth["tests"]]) - nominal
    assert drawn.shape == (48, 4)
    assert abs(drawn.std() / 0.2 - 1) < 0.2  # 192 draws: sd of the estimate ~5 %
    stops = np.array([r["stop_travel_m"] for r in truth["tests"]])
    assert stops.min() >= 0.05 and stops.max() <= 0.08 and stops.std() > 0.005


def test_other_physics_and_no_scatter():
    tests, truth = generate_lab_data(loads=(40.0,), repeats=2, effects=[], scatter_deg=0.0, noise_m=0.0)
    assert truth["effects"] == [] and truth["tests"][0]["tip_friction_deg"] is None
    assert truth["tests"][0]["friction_deg"] == [17.0, 14.0, 11.0]
    b = simulate(paper_model("B", 40.0), travel_m=truth["tests"][0]["stop_travel_m"])
    np.testing.assert_allclose(tests[0].positions, hermite_in_time(b, tests[0].t_s), atol=1e-12)


def test_a_block_that_never_slides_is_skipped():
    tests, truth = generate_lab_data(loads=(15.0, 40.0), repeats=1)
    assert [t.shear_force_N for t in tests] == [40.0]
    assert truth["skipped"][0]["test_id"] == "F15N-r1" and truth["skipped"][0]["status"] == "held"


@pytest.mark.parametrize("kwargs", [dict(repeats=0), dict(noise_m=-1.0), dict(rate_hz=0.0), dict(scatter_deg=-0.1),
                                    dict(stop_range_m=(0.08, 0.05)), dict(loads=()), dict(loads=(30.0, 30.0)),
                                    dict(loads=(-5.0,))])
def test_bad_arguments_are_refused(kwargs):
    with pytest.raises(ValueError):
        generate_lab_data(**kwargs)


def test_write_round_trip_and_truth_beside(tmp_path):
    tests, truth = generate_lab_data(**SMALL)
    data, truth_file = write_lab_data(tmp_path / "lab.csv", tests, truth)
    assert truth_file == tmp_path / "lab.csv.truth.json"
    back = read_measurements(data, rest_positions=REST)
    assert _same(tests, back)
    saved = json.loads(truth_file.read_text())
    assert saved["data_sha256"] == hashlib.sha256(data.read_bytes()).hexdigest()
    assert saved["data_file"] == "lab.csv" and saved["tests"] == truth["tests"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.csv", "lab.csv.truth.json"]  # no temporaries


def test_write_is_all_or_nothing(tmp_path):
    tests, truth = generate_lab_data(loads=(40.0,), repeats=1)
    target = tmp_path / "lab.csv"
    bad = tests + [MeasuredTest(tests[0].test_id, 40.0, tests[0].positions, tests[0].t_s)]  # duplicate id
    with pytest.raises(MeasurementError):
        write_lab_data(target, bad, truth)
    assert list(tmp_path.iterdir()) == []
    write_lab_data(target, tests, truth, tmp_path / "t.json")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    with pytest.raises(TypeError):  # truth not JSON-serialisable: nothing may change
        write_lab_data(target, tests, {**truth, "bad": object()}, tmp_path / "t.json")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_cli_writes_the_same_file_for_the_same_seed(tmp_path, capsys):
    args = ["lab-data", "--loads", "35,50", "--repeats", "1", "--seed", "4"]
    assert main(args + ["--out", str(tmp_path / "a.csv")]) == 0
    assert main(args + ["--out", str(tmp_path / "b.csv"), "--truth", str(tmp_path / "b.json")]) == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    assert json.loads((tmp_path / "b.json").read_text())["loads_N"] == [35.0, 50.0]
    assert "2 tests" in capsys.readouterr().out
    assert main(["lab-data", "--out", str(tmp_path / "c.csv"), "--repeats", "0"]) == 2


def test_shipped_dataset_is_what_the_documented_command_writes():
    """data/lab_traces.csv is what `triplanar lab-data --out data/lab_traces.csv` writes (data/README.md):
    the same tests, times and drawn values, positions within 1 um (byte-identical for the same core; the
    tolerance absorbs integrator-tolerance changes in the core, ~1e-9 m, and nothing physical)."""
    from pathlib import Path
    shipped = Path(__file__).resolve().parents[2] / "data" / "lab_traces.csv"
    tests, truth = generate_lab_data()
    saved_tests = read_measurements(shipped, rest_positions=REST)
    assert [t.test_id for t in saved_tests] == [t.test_id for t in tests]
    for a, b in zip(saved_tests, tests):
        np.testing.assert_array_equal(a.t_s, b.t_s)
        np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-6)
    saved = json.loads(shipped.with_name("lab_traces.csv.truth.json").read_text())
    assert saved["data_sha256"] == hashlib.sha256(shipped.read_bytes()).hexdigest()
    for a, b in zip(saved["tests"], truth["tests"]):
        assert (a["friction_deg"], a["tip_friction_deg"], a["stop_travel_m"]) == \
            (b["friction_deg"], b["tip_friction_deg"], b["stop_travel_m"])
