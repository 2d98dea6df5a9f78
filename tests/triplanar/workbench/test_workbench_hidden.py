"""Hidden-effect tests of diagnose: data made with an effect the model lacks.

Reduced datasets keep the suite fast: 4 loads x 2 repeats instead of 12 x 4, and 2 cross-validation folds
instead of 3 (the full 48-test runs, default settings, are in docs/workbench.md, made by
benchmarks/bench_workbench.py). Each case prints its numbers (run with ``-s``).

One parameter is not identifiable from so few tests, and the test says so instead of hiding it:
contact_friction's phi1 (CP1/FP1) trades off against phi2 along a valley of nearly equal error (on these
8 tests, phi1 from 12 to 21 deg fits to within 0.1 mm, well inside the repeat scatter), so its estimate
is only required to lie within two of its reported standard errors of the truth; on the full 48-test
dataset it lands within 15 % (docs/workbench.md).
"""

from __future__ import annotations

import pytest

from triplanar import make_effect
from triplanar.effects import REGISTRY
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ForwardSelection
from triplanar.workbench.scenarios import HIDDEN_EFFECTS, ForceRipple

pytestmark = pytest.mark.slow  # each test fits models to datasets: seconds to tens of seconds

LOADS = (27.8, 35.0, 45.0, 55.6)
REPEATS = 2
SEED = 1
FOLDS = 2
WEAK = {("contact_friction", "phi1_deg")}    # see the module doc

HIDDEN = HIDDEN_EFFECTS  # effect -> (data spec, parameters to recover within 15 %)


def lab(effects) -> list:
    tests, truth = generate_lab_data(loads=LOADS, repeats=REPEATS, effects=effects, seed=SEED)
    assert not truth["skipped"]
    return tests


def show(name: str, report: dict) -> None:
    print(f"\n[{name}] baseline {report['baseline_error_mm']:.3f} mm, scatter {report['repeat_scatter_mm']:.3f} mm "
          f"-> {report['verdict']}: {report['missing_effect']} ({report['confidence']}) in {report['seconds']:.1f} s; "
          f"periodic in {report['time_domain']['after_best']['periodic_fraction']:.0%} of the tests")
    for c in report["candidates"]:
        params = ", ".join(f"{k}={v:.4g}+-{c['param_stderr'][k]:.2g}" for k, v in c["params"].items())
        print(f"   {c['effect']:17s} cv {c['cv_error_mm']:7.3f} mm  improvement {c['improvement']:6.1%}  {params}"
              f"{'' if c['plausible'] else '  (implausible)'}")


# the diagnoses test_workbench_verdicts.py reads too (tests/triplanar/workbench/conftest.py): one worker, made once
SHARED = pytest.mark.xdist_group("default_diagnoses")


def marks(name: str) -> list:
    return [SHARED] if name == "rate_friction" else []


@pytest.mark.parametrize("name", [pytest.param(n, marks=marks(n)) for n in HIDDEN])
def test_hidden_builtin_effect_is_ranked_first_and_fitted(name: str, default_diagnosis) -> None:
    spec, truth = HIDDEN[name]
    report = default_diagnosis([spec], LOADS, REPEATS, SEED, FOLDS)[1].report_
    show(name, report)
    best = report["candidates"][0]
    assert best["effect"] == name
    for param, value in truth.items():
        error = abs(best["params"][param] - value)
        if (name, param) in WEAK:
            assert error <= max(0.15 * abs(value), 2 * best["param_stderr"][param]), (param, best["params"][param])
        else:
            assert error <= 0.15 * abs(value), (param, best["params"][param], value)
    assert report["missing_effect"] == name
    assert report["confidence"] in ("high", "low")
    if REGISTRY[name].acts_on == "instrument":
        # named as an instrument effect; a rangefinder's gain, offset or drift of the scenario's size leaves the
        # model as given within or near the repeats' scatter (a bias below it), so most of what remains is scatter
        assert report["missing_kind"] == "instrument"
        assert best["improvement"] > 0.1
    else:
        assert best["improvement"] >= 0.70
        assert report["missing_kind"] == "physics"


@SHARED
def test_no_hidden_effect_gives_null(default_diagnosis) -> None:
    report = default_diagnosis([], LOADS, REPEATS, SEED, FOLDS)[1].report_
    show("none", report)
    assert report["missing_effect"] is None
    assert report["confidence"] == "none"


def test_effect_outside_the_library_is_not_claimed_with_high_confidence() -> None:
    report = Diagnoser(folds=FOLDS, progress=False, executor="serial").fit(lab([ForceRipple(amp_N=6.0, freq_hz=6.0)])).report_
    show("force ripple (outside the library)", report)
    assert report["baseline_error_mm"] > 2 * report["repeat_scatter_mm"]   # there is something to explain
    assert report["confidence"] != "high"


def test_forward_selection_finds_two_hidden_effects() -> None:
    truth = {"end_friction": {"phi_deg": 8.0}, "tip_offset": {"offset_m": -0.005}}
    effects = [make_effect("end_friction:phi_deg=8"), make_effect("tip_offset:offset_m=-0.005")]
    sel = ForwardSelection(folds=FOLDS, progress=False, executor="serial").fit(lab(effects))
    print("\n[two effects]", [(s.added, round(s.error_mm, 3), s.effects) for s in sel.steps_], sel.stop_reason_)
    assert sorted(sel.added_) == sorted(truth)
    final = sel.steps_[-1].effects
    for name, params in truth.items():
        for param, value in params.items():
            assert abs(final[name][param] - value) <= 0.15 * abs(value)
    errors = [s.error_mm for s in sel.steps_]
    assert errors == sorted(errors, reverse=True)
    assert errors[-1] < 0.1 * errors[0]
