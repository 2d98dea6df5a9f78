"""A library verdict is not ``high`` when one extra force outside the library, with fewer parameters, predicts the
held-out loads as well (``rules._outside_force``, issue 33 item 5): evidence made by hand, no simulation."""

from __future__ import annotations

import math
from dataclasses import replace

from triplanar.workbench import rules
from triplanar.workbench.locate import LocatedResult, LocatedTerm
from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.rules import decide
from triplanar.workbench.spec import ModelSpec
from triplanar.workbench.sweep import CandidateResult
from triplanar.workbench.verdict import Evidence, VerdictKind, report_json

QUIET = {"systematic": False, "p_value_all": 1.0, "feature": None}
TESTS = [f"t{i}" for i in range(8)]


def _entry(effect: str, params: dict[str, float], cv: list[float]) -> CandidateResult:
    fitted = {k: FitParameter(effect, k, v, True, 0.0, 30.0, stderr=0.2, ci95=(v - 0.5, v + 0.5), status="fitted")
              for k, v in params.items()}
    rms = math.sqrt(sum(e * e for e in cv) / len(cv))
    return CandidateResult(effect, fitted, rms, rms, 1 - rms / 10.0, True, [],
                           held_out_mm=dict(zip(TESTS, cv)))


def _located(errors: list[float]) -> LocatedResult:
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    term = LocatedTerm("mass centre", "+e3", "constant", 2.5, (2.2, 2.8), "N", 0.9, rms)
    return LocatedResult(term, (), 10.0, rms, 0.9, 90, 400, len(errors), "an extra force at the mass centre",
                         dict(zip(TESTS, errors)))


def _evidence(best: CandidateResult, located: LocatedResult | None) -> Evidence:
    runner = _entry("cohesion", {"c_N": 1.0}, [3.0] * 8)
    return Evidence(ModelSpec(), ModelSpec(), {}, [[30.0], [40.0]], [], 10.0, {30.0: 10.0}, 0.5, 0.2, 0.1, 0.7, 0.2,
                    [best, runner], {}, QUIET, best, [], None, {}, math.nan, QUIET, located=located)


NAMED = [0.5, 0.6, 0.55, 0.5, 0.6, 0.55, 0.5, 0.6]
THREE = {"phi1_deg": 21.0, "phi2_deg": 13.0, "phi3_deg": 9.0}


def test_a_high_verdict_stays_high_without_a_rival_force_and_the_report_hides_the_evidence() -> None:
    ev = _evidence(_entry("contact_friction", THREE, NAMED), None)
    verdict = decide(ev)
    assert verdict.kind is VerdictKind.LIBRARY_EFFECT and verdict.confidence == "high", verdict.reason
    assert rules.locates(ev, verdict)
    worse = [e + 0.5 for e in NAMED]           # the force leaves clearly more on every held-out test
    located = decide(replace(ev, located=_located(worse)))
    assert located == verdict
    assert report_json(replace(ev, located=_located(worse)), located, 1.0)["located"] is None


def test_a_force_with_fewer_parameters_predicting_as_well_keeps_high_away() -> None:
    close = [e + (0.03 if i % 2 else -0.02) for i, e in enumerate(NAMED)]      # worse on average, by less than its se
    ev = _evidence(_entry("contact_friction", THREE, NAMED), _located(close))
    verdict = decide(ev)
    assert verdict.kind is VerdictKind.LIBRARY_EFFECT and verdict.missing_effect == "contact_friction"
    assert verdict.confidence == "low" and all(e.confidence == "low" for e in verdict.effects)
    said = verdict.reasons[-1]
    assert said.rule == "located.outside_force" and "mass centre" in said.text and "1 parameter(s) against the " \
        "named 3" in said.text, said.text
    assert said.value <= said.limit
    assert report_json(ev, verdict, 1.0)["located"]["term"]["direction"] == "+e3"


def test_a_force_with_as_many_parameters_as_the_named_entry_does_not_lower_it() -> None:
    one = _entry("end_friction", {"phi_deg": 8.0}, NAMED)
    ev = _evidence(one, _located([e - 0.05 for e in NAMED]))
    verdict = decide(ev)     # even a better-predicting force
    assert verdict.confidence == "high", verdict.reason
    assert not rules.locates(ev, verdict)           # so diagnose does not locate one at all


def test_the_force_lowers_high_within_outside_force_se_standard_errors_and_not_beyond() -> None:
    flat = [0.5] * 8
    best = _entry("contact_friction", THREE, flat)
    for z, fires in ((0.75 * rules.OUTSIDE_FORCE_SE, True), (1.25 * rules.OUTSIDE_FORCE_SE, False)):
        spread = 0.1                      # per-test differences mean +- spread: standard error spread / sqrt(7)
        mean = z * spread / math.sqrt(7)
        errors = [math.sqrt(0.25 + mean + (spread if i % 2 else -spread)) for i in range(8)]
        ev = _evidence(best, _located(errors))
        rival = rules.outside_force_rival(ev, decide(replace(ev, located=None)))
        assert math.isclose(rival["difference_mm2"] / rival["difference_se_mm2"], z, rel_tol=1e-9)
        assert decide(ev).confidence == ("low" if fires else "high"), (z, rival)


def test_a_weak_location_never_lowers_high() -> None:
    """A located force that does not beat the model alone on held-out loads is named for the user only (``weak``):
    the rule compares none, even with held-out errors as close as those that lower a ``high`` above."""
    close = [e + (0.03 if i % 2 else -0.02) for i, e in enumerate(NAMED)]
    ev = _evidence(_entry("contact_friction", THREE, NAMED), replace(_located(close), weak=True))
    assert decide(ev).confidence == "high"
