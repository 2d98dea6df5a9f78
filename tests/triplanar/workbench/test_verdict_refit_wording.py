"""A refit verdict says which given parameter was wrong and its new value (never "missing effect: none"), and each
clause of its reason names its rule and number: ``rules.decide`` on evidence made by hand (no simulation)."""

from __future__ import annotations

import math

from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.results import format_diagnosis
from triplanar.workbench.rules import EXPLAINED_FACTOR, decide
from triplanar.workbench.spec import ModelSpec
from triplanar.workbench.sweep import CandidateResult
from triplanar.workbench.verdict import Evidence, VerdictKind, report_json

QUIET = {"systematic": False, "p_value_all": 1.0, "feature": None}


def _entry(effect: str, param: str, value: float, ci: tuple[float, float], cv: float, errors: list[float],
           kind: str = "candidate", given: dict[str, float] | None = None) -> CandidateResult:
    p = FitParameter(effect, param, value, True, 0.0, 30.0, stderr=0.2, ci95=ci, status="fitted")
    return CandidateResult(effect, {param: p}, cv, cv, 1 - cv / 10.0, True, [], kind=kind, given=given or {},
                           held_out_mm={f"t{i}": e for i, e in enumerate(errors)})


def _evidence(ranked: list[CandidateResult]) -> Evidence:
    best = ranked[0]
    return Evidence(ModelSpec(), ModelSpec(), {}, [[30.0], [40.0]], [], 10.0, {30.0: 10.0}, 0.5, 0.2, 0.1, 0.7, 0.2,
                    ranked, {}, QUIET, best, [], None, {}, math.nan, QUIET)


def test_a_refit_verdict_names_the_wrong_given_parameter_and_its_new_value() -> None:
    refit = _entry("end_friction", "phi_deg", 8.12, (7.76, 8.48), 0.55, [0.5, 0.6, 0.55, 0.55], "refit",
                   {"phi_deg": 4.0})
    runner = _entry("contact_friction", "phi1_deg", 20.0, (15.0, 25.0), 1.42, [1.4, 1.5, 1.4, 1.4])
    ev = _evidence([refit, runner])
    verdict = decide(ev)
    assert verdict.kind is VerdictKind.REFIT_GIVEN_EFFECT and verdict.missing_effect is None
    assert verdict.confidence == "high", verdict.reason
    report = report_json(ev, verdict, 1.0)
    assert report["wrong_given"] == [{"effect": "end_friction", "param": "phi_deg", "given": 4.0, "fitted": 8.12,
                                      "ci95": [7.76, 8.48]}]
    line = next(x for x in format_diagnosis(report).splitlines() if x.startswith("verdict:"))
    assert "wrong given parameter: end_friction.phi_deg = 8.12 [7.76, 8.48] (given 4)" in line, line
    assert "missing effect" not in line and "none" not in line
    # each clause names its rule and the number it rests on
    leaving = next(r for r in verdict.reasons if r.text.startswith("leaving"))
    assert (leaving.rule, leaving.value, leaving.limit) == ("EXPLAINED_FACTOR", 0.55, EXPLAINED_FACTOR * 0.5)
    assert report["reason"] == "; ".join(r["text"] for r in report["reasons"])


def test_the_same_entry_leaving_too_much_is_outside_the_library_with_its_rule() -> None:
    refit = _entry("end_friction", "phi_deg", 8.12, (7.76, 8.48), 1.2, [1.2, 1.2, 1.2, 1.2], "refit",
                   {"phi_deg": 4.0})
    runner = _entry("contact_friction", "phi1_deg", 20.0, (15.0, 25.0), 3.0, [3.0, 3.0, 3.0, 3.0])
    verdict = decide(_evidence([refit, runner]))
    assert verdict.kind is VerdictKind.OUTSIDE_LIBRARY and verdict.effects == ()
    assert any(r.rule == "EXPLAINED_FACTOR" and r.text.startswith("but what remains is not noise")
               for r in verdict.reasons)
