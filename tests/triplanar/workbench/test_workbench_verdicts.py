"""Verdicts a scientist can trust, on datasets with a known truth (reduced: 4 loads x 2 repeats).

* a wrong given parameter is refitted and named (``refit_given_effect``);
* an out-of-library thrust ripple with a random phase per test is called ``outside_library``, with its frequency;
* a time-mostly effect (rate friction) is recognised from the evidence in time;
* the shipped dataset keeps its verdict under the report contract;
* 95 % intervals cover the truth in 85-99 % of seeded datasets (the project's own generator; ``long``).

Run with ``-s`` to print the numbers.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, EffectFit, ModelSpec, compare, load_tests
from triplanar.workbench.scenarios import ThrustRipple

pytestmark = pytest.mark.slow  # each test simulates and fits datasets: seconds to a minute

LOADS = (27.8, 35.0, 45.0, 55.6)
REPEATS = 2
FOLDS = 2
CONTRACT = {"verdict", "missing_effect", "confidence", "candidates", "refits", "noise", "time_domain"}
VERDICTS = {"none_missing", "library_effect", "refit_given_effect", "outside_library"}


def check_contract(report: dict) -> None:
    assert CONTRACT <= set(report)
    assert report["verdict"] in VERDICTS
    for c in report["candidates"]:
        assert set(c["params"]) == set(c["param_ci95"])
        for p, ci in c["param_ci95"].items():
            assert ci is None or (len(ci) == 2 and ci[0] <= c["params"][p] <= ci[1])
            assert c["param_status"][p] in ("fitted", "not_moved", "degenerate", "at_bound", "unidentified")
            assert (ci is None) == (c["param_status"][p] in ("not_moved", "degenerate"))
    for r in report["refits"]:
        assert {"effect", "param", "given", "fitted", "ci95", "cv_error_mm", "improvement"} <= set(r)
    assert {"instrument_noise_mm", "repeat_scatter_mm", "unexplained_error_mm"} <= set(report["noise"])
    assert {"arrival_error_s", "lag_rms_mm", "dominant_frequency_hz"} <= set(report["time_domain"])


def ripple_data(frac: float, freq_hz: float, seed: int = 1) -> list:
    """One dataset whose every test has its own random phase (as a motor's ripple would)."""
    rng = np.random.default_rng(seed)
    tests = []
    for force in LOADS:
        for repeat in range(1, REPEATS + 1):
            ripple = ThrustRipple(frac=frac, freq_hz=freq_hz, phase_rad=float(rng.uniform(0.0, 2 * math.pi)))
            made, _ = generate_lab_data(loads=[force], repeats=1, effects=[ripple], seed=seed * 100 + repeat)
            tests += [replace(t, test_id=f"F{force:g}N-r{repeat}") for t in made]
    return tests


def lab(effects, seed: int = 1, loads=LOADS, repeats: int = REPEATS) -> list:
    tests, truth = generate_lab_data(loads=loads, repeats=repeats, effects=effects, seed=seed)
    assert not truth["skipped"]
    return tests


def test_a_wrong_given_parameter_is_refitted_and_named() -> None:
    tests = lab([make_effect("end_friction:phi_deg=8")])
    given = ModelSpec.from_effects([make_effect("end_friction:phi_deg=4")])
    diag = Diagnoser(folds=FOLDS, progress=False, model_form=False, executor="serial").fit(tests, given)  # conftest.py
    report = diag.report_
    print("\n[wrong given]", report["verdict"], report["reason"], report["refits"])
    check_contract(report)
    assert report["verdict"] == "refit_given_effect"
    assert report["missing_effect"] is None
    (refit,) = report["refits"]
    assert refit["effect"] == "end_friction" and refit["param"] == "phi_deg" and refit["given"] == 4.0
    assert refit["fitted"] == pytest.approx(8.0, abs=0.5)
    assert refit["ci95"][0] <= 8.0 <= refit["ci95"][1]
    assert refit["improvement"] > 0.7
    # the same from fit: an --add of an effect the model has frees it
    fit = EffectFit(["end_friction"], executor="serial").fit(tests, given)
    assert fit.refitted_ == {"end_friction": {"phi_deg": 4.0}}
    assert fit.params_["end_friction"]["phi_deg"] == pytest.approx(refit["fitted"], abs=0.05)
    assert fit.error_mm_ < 0.3 * fit.baseline_error_mm_


def test_an_out_of_library_periodic_force_is_called_so_with_its_frequency() -> None:
    report = Diagnoser(folds=FOLDS, progress=False, executor="serial").fit(ripple_data(0.3, 10.0)).report_
    print("\n[ripple 10 Hz, 30 %, random phase]", report["verdict"], report["reason"], report["time_domain"])
    check_contract(report)
    assert report["verdict"] == "outside_library"
    assert report["confidence"] != "high"
    assert 8.0 <= report["time_domain"]["dominant_frequency_hz"] <= 13.0
    assert "periodic at" in report["reason"]


# the diagnoses test_workbench_hidden.py reads too (tests/triplanar/workbench/conftest.py): one worker, made once
SHARED = pytest.mark.xdist_group("default_diagnoses")


@SHARED
def test_a_time_mostly_effect_is_recognised_from_the_evidence_in_time(default_diagnosis) -> None:
    tests, diag = default_diagnosis(["rate_friction:a=0.3"], LOADS, REPEATS, 1, FOLDS)
    cmp = compare(tests, ModelSpec())
    pattern = cmp.pattern()
    print("\n[rate friction]", pattern)
    assert pattern.startswith("the error is mostly in time")
    report = diag.report_
    print(report["reason"])
    check_contract(report)
    assert report["time_domain"]["mostly_in_time"]
    assert report["verdict"] == "library_effect" and report["missing_effect"] == "rate_friction"
    assert "mostly in time" in report["reason"]


@SHARED
def test_no_effect_is_none_missing_and_the_shipped_dataset_keeps_its_verdict(default_diagnosis) -> None:
    report = default_diagnosis([], LOADS, REPEATS, 1, FOLDS)[1].report_
    check_contract(report)
    assert report["verdict"] == "none_missing"
    root = Path(__file__).resolve().parents[3]
    # two candidates and no model-form step (conftest.py: not read) keep it quick; the full run is in
    # docs/workbench.md (same verdict)
    shipped = Diagnoser(["end_friction", "tip_offset"], progress=False, model_form=False, executor="serial").fit(
        load_tests(root / "data" / "lab_traces.csv")).report_
    print("\n[shipped]", shipped["reason"], shipped["noise"])
    check_contract(shipped)
    assert shipped["verdict"] == "library_effect" and shipped["missing_effect"] == "end_friction"
    lo, hi = shipped["candidates"][0]["param_ci95"]["phi_deg"]
    assert lo <= 8.0 <= hi
    assert shipped["noise"]["instrument_noise_mm"] == pytest.approx(0.2, rel=0.1)   # the generator's 0.2 mm


COVERAGE_SEEDS = range(30)


@pytest.mark.long  # a coverage rate over 30 seeded fits (~15 CPU s, at the cheapest fit per seed): fewer seeds cannot
#                    tell 95 % from 85 %, so it cannot be made cheaper; `make test-slow` runs it
def test_interval_coverage_over_seeded_datasets() -> None:
    """The cheapest fit that still exercises the interval method: one parameter (end friction), 3 loads x 2
    repeats, 2 folds (sandwich, jackknife and the model-form factor all enter). Binomial uncertainty of the
    coverage over 30 datasets: sqrt(p (1 - p) / 30), about 4 points at 95 %."""
    hits, widths = 0, []
    for seed in COVERAGE_SEEDS:
        tests = lab([make_effect("end_friction:phi_deg=8")], seed=100 + seed, loads=(35.0, 45.0, 55.6))
        diag = Diagnoser(["end_friction"], folds=FOLDS, executor="serial", progress=False,
                         refit_given=False, model_form=False).fit(tests)      # the curvature interval only
        lo, hi = diag.candidates_[0].param_ci95["phi_deg"]
        hits += lo <= 8.0 <= hi
        widths.append(hi - lo)
    n = len(COVERAGE_SEEDS)
    coverage = hits / n
    print(f"\n[coverage] {hits}/{n} = {coverage:.0%} +- {math.sqrt(coverage * (1 - coverage) / n):.0%}; "
          f"median width {np.median(widths):.3f} deg")
    assert 0.85 <= coverage <= 0.99
