"""Workbench building blocks: discrepancy, evaluation tasks, executors, fits, candidates, the pattern text."""

from __future__ import annotations

import math
import pickle
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from triplanar.specimen import Foundation, Plane, reference

from triplanar import EffectError, MeasuredTest, make_effect, paper_model, simulate
from triplanar.labdata import generate_lab_data
from triplanar.workbench import (Candidate, CandidateTask, Diagnoser, EffectFit, EvalTask, ModelSpec, compare,
                                 describe_pattern, discrepancy, evaluate, repeat_scatter_mm)
from triplanar.workbench.candidates import candidate_library
from triplanar.workbench.diagnose import load_folds
from triplanar.outcome import Outcome
from triplanar.workbench.fit import safe_evaluate

LOADS = (27.8, 40.0, 55.6)
REST = reference()[0].contact_points_m


@pytest.fixture(scope="module")
def case_a_data() -> list[MeasuredTest]:
    tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=3)
    return tests


def test_model_against_its_own_trace_has_no_discrepancy() -> None:
    result = simulate(paper_model("A", 35.0), travel_m=0.07)
    measured = result.to_measured("self")
    d = discrepancy(measured, simulate(paper_model("A", 35.0), travel_m=0.075))
    assert d.status == "travel"
    assert d.error_mm < 1e-3 and d.max_mm.max() < 1e-3
    assert abs(d.rotation_error_deg) < 1e-4 and np.all(np.abs(d.dilation_error_mm) < 1e-3)
    assert abs(d.arrival_error_s) < 1e-6 and d.lag_rms_mm < 1e-3
    assert math.isclose(float(np.sum(d.residuals ** 2)), d.error_mm ** 2, rel_tol=1e-9, abs_tol=1e-15)


def test_case_b_against_case_a_shows_the_papers_signature() -> None:
    measured = simulate(paper_model("A", 32.5), travel_m=0.07).to_measured("A")
    d = discrepancy(measured, simulate(paper_model("B", 32.5), travel_m=0.075))
    # Paper section 5.2: case B dilates CP1 toward +e3 far more than the measured (case A) block, and turns
    # the other way.
    assert d.dilation_error_mm[0] < -10.0
    assert d.rotation_error_deg > 5.0
    assert d.arrival_error_s < 0          # no end friction: the model is faster
    assert math.isclose(float(np.sum(d.residuals ** 2)), d.error_mm ** 2, rel_tol=1e-9)


def test_without_time_the_lag_is_left_out() -> None:
    run = simulate(paper_model("A", 40.0), travel_m=0.06)
    timed = run.to_measured("t")
    flat = timed.positions.copy()
    flat[:, :, 1] = np.nan                                  # no vertical either
    untimed = MeasuredTest("u", 40.0, flat, None)
    d = discrepancy(untimed, simulate(paper_model("B", 40.0), travel_m=0.065))
    assert math.isnan(d.lag_rms_mm) and math.isnan(d.arrival_error_s) and np.all(np.isnan(d.vertical_rms_mm))
    assert np.count_nonzero(d.residuals) <= 6 * untimed.n_samples
    assert math.isclose(float(np.sum(d.residuals ** 2)), d.error_mm ** 2, rel_tol=1e-9)


def test_a_model_that_holds_is_reported_not_raised() -> None:
    measured = simulate(paper_model("A", 40.0), travel_m=0.05).to_measured("slides")
    slow = MeasuredTest("low", 12.0, measured.positions, measured.t_s)
    out = evaluate(EvalTask(ModelSpec(), 12.0, (slow,)))
    assert out.status == "held" and out.threshold_N is not None and 12.0 < out.threshold_N < 40.0
    d = out.discrepancies[0]
    assert d.coverage == 0.0 and d.error_mm > 10.0      # the whole measured motion is the discrepancy
    cmp = compare([slow], ModelSpec())
    assert "never slides" in cmp.note(d) and f"{out.threshold_N:.2f} N" in cmp.note(d)
    assert "never slides" in cmp.pattern()


def test_a_model_the_core_refuses_counts_as_not_moving_in_fits() -> None:
    measured = simulate(paper_model("B", 40.0), travel_m=0.05).to_measured("x")
    # FP2 dipping 25 degrees off the drawing's direction: CP2 lies 17 mm off its plane, which the core refuses.
    spec = ModelSpec(foundation=Foundation((Plane(0.0), Plane(9.5, 205.0), Plane(20.0, 150.0))))
    with pytest.raises(ValueError):
        evaluate(EvalTask(spec, 40.0, (measured,)))
    out = safe_evaluate(EvalTask(spec, 40.0, (measured,)))
    assert out.status == "invalid" and "refused" in out.message
    assert out.discrepancies[0].error_mm > 10.0
    assert out.discrepancies[0].status == "invalid" and out.discrepancies[0].outcome is None   # no run: no Outcome
    ran = safe_evaluate(EvalTask(ModelSpec(), 40.0, (measured,))).discrepancies[0]
    assert ran.outcome is Outcome.from_label(ran.status) and ran.outcome is not None


def test_repeat_scatter() -> None:
    run = simulate(paper_model("A", 40.0), travel_m=0.06).to_measured("a")
    twin = MeasuredTest("b", 40.0, run.positions, run.t_s)
    # identical repeats: no scatter but the integrator's tolerance, which a perfect simulated model still shows
    from triplanar.workbench.discrepancy import INTEGRATOR_FLOOR_MM
    assert repeat_scatter_mm([run, twin], REST) == INTEGRATOR_FLOOR_MM
    assert math.isnan(repeat_scatter_mm([run], REST))
    shifted = MeasuredTest("c", 40.0, run.positions + np.array([0.0, 0.0, 0.001]), run.t_s)
    # Two repeats 1 mm apart laterally at every CP: each is 0.5 mm from the mean, x sqrt(2) for the true path.
    assert repeat_scatter_mm([run, shifted], REST) == pytest.approx(math.sqrt(3 * 0.5 ** 2 * 2 / 4), rel=1e-6)


def test_tasks_pickle_and_a_process_pool_gives_the_same_answer(case_a_data) -> None:
    spec = ModelSpec.from_effects([make_effect("end_friction:phi_deg=7")])
    task = EvalTask(spec, LOADS[0], tuple(t for t in case_a_data if t.shear_force_N == LOADS[0]))
    assert pickle.loads(pickle.dumps(task)).spec == spec
    serial = evaluate(task)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = list(pool.map(evaluate, [task]))[0]
    assert [d.error_mm for d in pooled.discrepancies] == pytest.approx([d.error_mm for d in serial.discrepancies])
    cand = candidate_library(["end_friction"])[0]
    pickle.dumps(CandidateTask(ModelSpec(), cand, tuple(case_a_data), ((27.8,), (40.0, 55.6))))


class CountingExecutor:
    """A user-supplied executor: anything with map(fn, iterable)."""

    def __init__(self) -> None:
        self.calls = 0

    def map(self, fn, iterable):
        self.calls += 1
        return [fn(x) for x in iterable]


def test_diagnose_uses_a_pluggable_executor_and_reports_the_schema(case_a_data) -> None:
    ex = CountingExecutor()
    diag = Diagnoser(["end_friction", "tip_offset"], folds=3, executor=ex, progress=False).fit(case_a_data)
    audit = 1 + any(a.fitted is not None for a in diag.evidence_.given_numbers)   # given numbers: screen, full fits
    assert ex.calls == (2 if diag.best_ is not None else 1) + audit   # the sweep, then the named entry's model-form fits
    report = diag.report_
    assert set(report) >= {"baseline_error_mm", "candidates", "missing_effect", "confidence"}
    assert report["confidence"] in ("high", "low", "none")
    for c in report["candidates"]:
        assert set(c) >= {"effect", "params", "param_stderr", "cv_error_mm", "improvement"}
        assert set(c["params"]) == set(c["param_stderr"])
    errors = [c["cv_error_mm"] for c in report["candidates"]]
    assert errors == sorted(errors)
    assert report["missing_effect"] == "end_friction"
    assert diag.score(case_a_data) > 0.7


def test_effect_fit_recovers_end_friction(case_a_data) -> None:
    fit = EffectFit(["end_friction"], executor="serial").fit(case_a_data)
    assert fit.params_["end_friction"]["phi_deg"] == pytest.approx(8.0, rel=0.15)
    assert 0 < fit.stderr_["end_friction"]["phi_deg"] < 2.0
    assert fit.error_mm_ < 0.2 * fit.baseline_error_mm_
    assert set(fit.error_by_load_) == set(LOADS)
    assert fit.predict(40.0).status.label == "travel"
    # adding an effect the model already has refits it, from the value given
    given = ModelSpec.from_effects([make_effect("end_friction:phi_deg=4")])
    refit = EffectFit(["end_friction"], executor="serial").fit(case_a_data, given)
    assert refit.refitted_ == {"end_friction": {"phi_deg": 4.0}}
    assert refit.params_["end_friction"]["phi_deg"] == pytest.approx(8.0, rel=0.15)
    with pytest.raises(EffectError, match="already in the model"):
        EffectFit(["end_friction", "end_friction"]).fit(case_a_data)


def test_candidates_are_validated() -> None:
    with pytest.raises(EffectError, match="known effects"):
        Candidate("no_such_effect", ("x",), {"x": (0, 1)})
    with pytest.raises(EffectError, match="fit range"):
        Candidate("end_friction", ("phi_deg",), {"phi_deg": (-5.0, 10.0)})
    names = [c.effect for c in candidate_library(exclude=["end_friction"])]
    assert "end_friction" not in names and {"rate_friction", "plane_tilt"} <= set(names)
    rise = candidate_library(["actuator_rise"])[0]
    assert rise.values({"tau_s": 0.001}) == {"tau_s": 0.0} and rise.values({"tau_s": 0.05}) == {"tau_s": 0.05}


def test_folds_interleave_load_levels() -> None:
    assert load_folds([30.0, 10.0, 20.0, 40.0, 10.0], 3) == [[10.0, 40.0], [20.0], [30.0]]
    assert load_folds([10.0], 3) == [[10.0]]


def test_pattern_sentence_for_case_b_against_case_a(case_a_data) -> None:
    cmp = compare(case_a_data, ModelSpec())
    text = cmp.pattern()
    assert "shrinking as load grows" in text
    assert "dilates CP1 more toward +x3" in text
    assert "counter-clockwise" in text
    assert describe_pattern([]) == "no tests"
    rows = cmp.rows()
    assert len(rows) == 3 * len(case_a_data) and {r["cp"] for r in rows} == {1, 2, 3}
