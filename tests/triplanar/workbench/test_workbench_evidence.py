"""The evidence behind a verdict, fast parts: noise estimate, residual spectrum, intervals' statuses, --start
parsing, BlockState."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from triplanar import EffectError, paper_model
from triplanar.measurement import MeasuredTest
from triplanar.commands.workbench_options import parse_starts
from triplanar.workbench.discrepancy import TestDiscrepancy
from triplanar.workbench.evidence import dominant_frequency, instrument_noise_mm, noise_floor_mm, time_domain
from triplanar.workbench.intervals import inflation, interval95

ROOT = Path(__file__).resolve().parents[3]


def _smooth_test(noise_m: float, seed: int = 0, n: int = 200) -> MeasuredTest:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    base = np.array([[-0.1, 0.0, 0.0], [0.1, 0.01, 0.05], [0.1, 0.02, -0.05]])
    path = base[None] + (0.4 * t**2)[:, None, None] * np.array([1.0, 0.1, 0.3])[None, None, :]
    return MeasuredTest("T1", 30.0, path + rng.normal(0.0, noise_m, path.shape), t)


@pytest.mark.parametrize("noise_m", [1e-4, 2e-4, 5e-4])
def test_instrument_noise_is_recovered_from_second_differences(noise_m: float) -> None:
    tests = [_smooth_test(noise_m, seed) for seed in range(4)]
    assert instrument_noise_mm(tests) == pytest.approx(noise_m * 1e3, rel=0.08)


def test_noise_floor_counts_the_measured_coordinates_and_the_lag() -> None:
    test = _smooth_test(2e-4)
    # 3 CPs x 3 coordinates + the lag, over 4 groups
    assert noise_floor_mm([test], 0.2) == pytest.approx(0.2 * math.sqrt(10 / 4))


def _residual(signal: np.ndarray, t: np.ndarray, rng: np.random.Generator) -> TestDiscrepancy:
    """A test whose four residual series (lateral CP1-3, lag) carry ``signal`` plus independent 0.2 mm noise."""
    n = len(t)
    series = signal[:, None] * np.array([1.0, 0.5, 0.2, 1.0])[None, :] + rng.normal(0.0, 0.2, (n, 4))
    return TestDiscrepancy("T", 30.0, "travel", "", np.ones(3), np.ones(3), np.zeros(3), 0.0, 0.01, 1.0, 1.0, 1.0,
                           np.linspace(0.0, 0.07, n), series[:, :3], np.zeros(1), np.full(3, math.nan),
                           series[:, 3], t)


def test_a_periodic_residual_is_found_and_white_noise_is_not() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(160) / 200.0
    periodic = [_residual(0.5 * np.sin(2 * np.pi * 9.4 * t + p), t, rng) for p in rng.uniform(0, 6.3, 10)]
    freqs = [dominant_frequency(d) for d in periodic]
    assert all(yes for _, yes in freqs)
    assert all(abs(f - 9.4) < 1.5 for f, _ in freqs)          # resolution 1.25 Hz over 0.8 s
    td = time_domain(periodic)
    assert td["dominant_frequency_hz"] == pytest.approx(9.4, abs=1.5)
    noise = [_residual(3.0 * t**2, t, rng) for _ in range(40)]   # a trend and white noise, nothing periodic
    td = time_domain(noise)
    assert td["dominant_frequency_hz"] is None
    assert td["periodic_fraction"] <= 0.1


def test_interval_statuses_and_model_form_widening() -> None:
    args = dict(n_tests=48, n_free=1, bounds=(0.0, 44.0), fit_range=(0.0, 30.0))
    ci, status = interval95(8.0, 0.1, 0.05, fit_error_mm=0.5, scatter_mm=0.5, start=0.0, **args)
    assert status == "fitted" and ci[0] < 8.0 < ci[1]
    width = ci[1] - ci[0]
    assert width == pytest.approx(2 * 2.012 * 0.1, rel=1e-3)        # t(0.975, 47) x stderr, both sides
    wide, _ = interval95(8.0, 0.1, 0.05, fit_error_mm=1.5, scatter_mm=0.5, start=0.0, **args)
    assert wide[1] - wide[0] == pytest.approx(3 * width)             # error 3 x the scatter: 3 x wider
    assert inflation(0.3, 0.5) == 1.0
    assert interval95(0.0, 0.1, 0.0, fit_error_mm=1, scatter_mm=1, start=0.0, **args) == (None, "not_moved")
    assert interval95(8.0, 0.0, 0.0, fit_error_mm=1, scatter_mm=1, start=0.0, **args) == (None, "degenerate")
    assert interval95(8.0, math.nan, 0.2, fit_error_mm=1, scatter_mm=1, start=0.0, **args) == (None, "degenerate")
    ci, status = interval95(8.0, 20.0, 0.0, fit_error_mm=1, scatter_mm=1, start=0.0, **args)
    assert status == "unidentified" and ci == [0.0, 44.0]         # spans the whole fit range: said so


def test_start_values_are_parsed_and_bad_ones_named() -> None:
    assert parse_starts(["end_friction:phi_deg=5"]) == {"end_friction": {"phi_deg": 5.0}}
    with pytest.raises(EffectError, match="no parameter"):
        parse_starts(["end_friction:phi=5"])
    with pytest.raises(EffectError, match="outside"):
        parse_starts(["end_friction:phi_deg=95"])
    with pytest.raises(EffectError, match="NAME:P=V"):
        parse_starts(["end_friction"])
    with pytest.raises(EffectError, match="twice"):
        parse_starts(["end_friction:phi_deg=5", "end_friction:phi_deg=6"])


def test_block_state_has_load_point_thrust_specimen_and_time() -> None:
    model = paper_model("B", 30.0)
    state = model.block_state(0.0, model.initial_state())
    assert np.allclose(state.load_point, model.specimen.load_point_world)   # at rest, P_L is the drawn load point
    assert np.allclose(state.thrust_direction, [1.0, 0.0, 0.0])
    assert state.thrust_N == 30.0
    assert state.specimen is model.specimen
    assert state.time_since_actuator_s == 0.0


def test_diagnose_cli_refuses_a_bad_start_value(tmp_path, capsys) -> None:
    from triplanar.cli import main
    code = main(["diagnose", str(ROOT / "data" / "lab_traces.csv"), "--out", str(tmp_path),
                 "--start", "end_friction:phi_deg=-3"])
    assert code == 2
    assert "phi_deg" in capsys.readouterr().err


def test_a_fit_starts_at_a_parameters_start_apart_from_neutral() -> None:
    from triplanar import Effect, Parameter
    from triplanar.workbench.candidates import default_candidate
    from triplanar.effects import REGISTRY

    class Wobble(Effect):
        name = "wobble_start_test"
        parameters = {"amp_N": Parameter(0.0, 0.0, 10.0, "N", "amplitude", start=1.0),
                      "freq_hz": Parameter(5.0, 1.0, 20.0, "Hz", "frequency")}

    REGISTRY[Wobble.name] = Wobble
    try:
        cand = default_candidate(Wobble.name)
        assert cand.start_values() == {"amp_N": 1.0, "freq_hz": 5.0}
        assert Wobble().values["amp_N"] == 0.0            # the default still does nothing
    finally:
        del REGISTRY[Wobble.name]


def test_a_model_given_as_b_plus_end_friction_is_named_case_a() -> None:
    from triplanar import make_effect
    from triplanar.workbench import ModelSpec
    assert ModelSpec.from_effects([make_effect("end_friction:phi_deg=8")]).describe() == "case A (end friction)"
    assert ModelSpec.from_effects([make_effect("end_friction:phi_deg=4"), make_effect("tip_offset:offset_m=0.001")]
                                  ).describe() == "case A (end friction, phi_EF = 4 deg) + tip_offset:offset_m=0.001"


def test_diagnose_start_values_move_a_candidates_start_and_widen_its_range() -> None:
    from triplanar.workbench import Diagnoser
    from triplanar.workbench.candidates import default_candidate
    cand = Diagnoser(start={"tip_offset": {"offset_m": 0.03}})._with_start(default_candidate("tip_offset"))
    assert cand.start_values() == {"offset_m": 0.03}
    assert cand.bounds["offset_m"][1] == 0.03                      # the plausible range now contains the start
    with pytest.raises(ValueError, match="not a free parameter"):
        Diagnoser(start={"rate_friction": {"v0_m_s": 0.1}})._with_start(default_candidate("rate_friction"))


def test_expected_scatter_shifts_the_angles_a_contact_friction_effect_sets() -> None:
    """With contact_friction in the model, shifting the specimen's angles would change nothing and the repeats'
    scatter would look unexplained (found by benchmarks/threshold_check.py): the angles in use are shifted."""
    from triplanar import make_effect
    from triplanar.labdata import generate_lab_data
    from triplanar.workbench import ModelSpec, evaluate_spec
    from triplanar.workbench.evidence import expected_scatter_mm
    from triplanar.workbench.fit import discrepancies
    tests, _ = generate_lab_data(loads=(40.0,), repeats=2, seed=1)
    def evaluate(spec, ts):
        return discrepancies(evaluate_spec(spec, ts))
    plain = expected_scatter_mm(ModelSpec.from_effects([make_effect("end_friction:phi_deg=8")]), tests, 0.2, 0.2,
                                evaluate)
    same = ModelSpec.from_effects([make_effect("end_friction:phi_deg=8"),
                                   make_effect("contact_friction:phi1_deg=15,phi2_deg=17,phi3_deg=10")])
    floor = noise_floor_mm(tests, 0.2)
    assert plain > 1.2 * floor
    assert expected_scatter_mm(same, tests, 0.2, 0.2, evaluate) == pytest.approx(plain, rel=0.2)
