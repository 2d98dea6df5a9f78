"""A bias common to all tests below the repeats' scatter lets an entry removing less than ``MIN_IMPROVEMENT`` be
examined only when it is stronger than ``HIDDEN_BIAS_ALPHA`` (the calibration's tuning part, seeds 1000-1033 and
2000-2065: a clean dataset showed p = 0.0091, outside causes 2e-3 to 4e-3; ``rules.examined_entry``). A weaker one
is said in the reason, but names nothing: the verdict is ``none_missing``. Evidence made by hand: no simulation."""

from __future__ import annotations

import math

from triplanar.workbench import rules
from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.rules import decide, examined_entry
from triplanar.workbench.spec import ModelSpec
from triplanar.workbench.sweep import CandidateResult
from triplanar.workbench.verdict import Evidence, VerdictKind

QUIET = {"systematic": False, "p_value_all": 1.0, "feature": None}
WEAK = {"systematic": True, "p_value_all": 0.002, "feature": "mean x3 error CP1 (mm)", "mean": 0.1, "levels": 4,
        "z": 3.5}
STRONG = {**WEAK, "p_value_all": 1e-6, "z": 5.5}


def _entry(improvement: float, baseline_mm: float) -> CandidateResult:
    cv = (1 - improvement) * baseline_mm
    p = FitParameter("rangefinder_gain", "gain_x3", 1.1, True, 0.5, 1.5, stderr=0.01, ci95=(1.08, 1.12),
                     status="fitted")
    return CandidateResult("rangefinder_gain", {"gain_x3": p}, cv, cv, improvement, True, [],
                           held_out_mm={f"t{i}": cv for i in range(6)})


def _evidence(improvement: float, bias: dict) -> Evidence:
    base, scatter = 0.9, 0.75               # the model as given within QUIET_FACTOR x the scatter (1.2)
    entry = _entry(improvement, base)
    best, look = examined_entry([entry], base, scatter, bias["p_value_all"])
    after = bias if best is None else QUIET
    return Evidence(ModelSpec(), ModelSpec(), {}, [[30.0], [40.0]], [], base, {30.0: base}, scatter, 0.3, 0.1, 0.6,
                    0.2, [entry], {}, bias, best, look, None, {}, math.nan, after)


def test_a_weak_bias_below_the_scatter_is_said_but_names_nothing() -> None:
    assert rules.HIDDEN_BIAS_ALPHA < WEAK["p_value_all"] < rules.SYSTEMATIC_ALPHA
    ev = _evidence(0.22, WEAK)              # removes 22 %: below MIN_IMPROVEMENT
    assert ev.best is None
    verdict = decide(ev)
    assert verdict.kind is VerdictKind.NONE_MISSING and not verdict.effects, verdict.reason
    said = verdict.reasons[-1]
    assert said.rule == "SYSTEMATIC_ALPHA" and "rangefinder_gain, 22%" in said.text and "no library entry" in said.text


def test_a_strong_bias_or_an_entry_that_removes_enough_of_it_is_judged() -> None:
    for improvement, bias in ((0.22, STRONG), (rules.MIN_IMPROVEMENT + 0.05, WEAK)):
        ev = _evidence(improvement, bias)
        assert ev.best is not None, (improvement, bias["p_value_all"])
        verdict = decide(ev)
        assert verdict.kind is VerdictKind.LIBRARY_EFFECT and verdict.missing_effect == "rangefinder_gain", \
            verdict.reason
