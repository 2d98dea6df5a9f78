"""What a diagnosis gathers and what it concludes, as values: :class:`Evidence` in, :class:`Verdict` out.

:class:`~triplanar.workbench.diagnose.Diagnoser` gathers the :class:`Evidence` (the fits, their intervals, the
scatter, the residual's patterns, the look-alikes, the combination tried, the deciding experiments);
:func:`triplanar.workbench.rules.decide`, and nothing else, turns it into a :class:`Verdict`. The JSON report
(:func:`report_json`) and the printout (:func:`triplanar.workbench.results.format_diagnosis`, of that report) are
views of the two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any, Mapping, Sequence

if TYPE_CHECKING:
    from .discrepancy import TestDiscrepancy
    from .given_audit import GivenAudit
    from .locate import LocatedResult
    from .rigidity import RigidityResult
    from .spec import ModelSpec
    from .candidate_result import CandidateResult


class VerdictKind(str, Enum):
    """What the verdict says (the report's ``verdict`` field is its value)."""

    NONE_MISSING = "none_missing"                  # the model matches the data to within noise and the specimen
    LIBRARY_EFFECT = "library_effect"              # one library effect, added, explains the data
    LIBRARY_EFFECTS = "library_effects"            # two or more, together, do
    REFIT_GIVEN_EFFECT = "refit_given_effect"      # a parameter the user gave is wrong; its refitted value explains
    OUTSIDE_LIBRARY = "outside_library"            # what remains is not noise, and no library entry explains it


@dataclass(frozen=True)
class Reason:
    """One clause of the verdict's reason: its sentence, the rule that made it (a constant of
    :mod:`~triplanar.workbench.rules` or the name of the test) and the number it rests on (with the limit it was
    held against, where the rule has one)."""

    text: str
    rule: str
    value: float | None = None
    limit: float | None = None

    def as_json(self) -> dict[str, Any]:
        return {"text": self.text, "rule": self.rule, "value": self.value, "limit": self.limit}


@dataclass(frozen=True)
class NamedEffect:
    """An entry the verdict names: a candidate added, or a given effect refitted (``given``: the values the user gave
    that the refit replaced). ``report``: its line of the report's ``missing_effects`` (the fields there)."""

    effect: str
    kind: str                                   # "candidate" or "refit"
    params: Mapping[str, float]
    param_ci95: Mapping[str, Sequence[float] | None]
    confidence: str
    given: Mapping[str, float] = field(default_factory=dict)
    report: Mapping[str, Any] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        return dict(self.report)

    def wrong_given(self) -> list[dict[str, Any]]:
        """A refit's wrong given parameters: ``{effect, param, given, fitted, ci95}`` of each it moved."""
        if self.kind != "refit":
            return []
        return [{"effect": self.effect, "param": p, "given": self.given.get(p), "fitted": v,
                 "ci95": None if self.param_ci95.get(p) is None else list(self.param_ci95[p])}
                for p, v in self.params.items()]


@dataclass(frozen=True)
class Verdict:
    """The conclusion of a diagnosis (:func:`triplanar.workbench.rules.decide` makes it, nothing else).

    ``effects``: the named entries, in order (empty when nothing is named); ``missing_effect``: the library effect the
    report names (a candidate; ``None`` for a refit or when nothing is named); ``reasons``: the clauses of the reason,
    each with its rule and number; ``combination``: the forward selection tried, as judged (``steps``,
    ``cv_error_mm``, ``explains``, ``periodic``), or ``None``; ``unexplained_mm``: what the verdict leaves
    unexplained (the named entries' cross-validated error, else the baseline)."""

    kind: VerdictKind
    effects: tuple[NamedEffect, ...]
    missing_effect: str | None
    confidence: str
    reasons: tuple[Reason, ...]
    unexplained_mm: float
    combination: Mapping[str, Any] | None = None
    #: look-alike groups, ``{"members": [...], "source": "effects" | "given", "deciding_measurement": ...}``: a named
    #: entry with the entries the data cannot tell from it, or with a given number of the specimen
    groups: tuple[Mapping[str, Any], ...] = ()

    @property
    def reason(self) -> str:
        """The reason in one sentence (the report's ``reason``)."""
        return "; ".join(r.text for r in self.reasons)


@dataclass(frozen=True)
class Combination:
    """Forward selection from the best single entry (:func:`triplanar.workbench.combine.combine`): per step its
    entry, error, share of the improvement, runner-up and look-alikes, its parameters from the last joint fit; the
    combination's cross-validated error, the residual after it (periodic, systematic), its model, and the uncertainty
    of its advantage over the best single entry (``gain_mm2``, ``gain_se_mm2``: held-out squared error, mean over
    the tests and its standard error)."""

    steps: tuple[Mapping[str, Any], ...]
    cv_error_mm: float
    periodic: bool
    systematic: bool
    spec: ModelSpec | None
    after: list[TestDiscrepancy] | None
    time_domain_after: Mapping[str, Any]
    growth_after: float
    gain_mm2: float = math.nan
    gain_se_mm2: float = math.nan
    #: the combination's held-out error per test (mm, by ``test_id``; empty: gathered before it was kept)
    held_out_mm: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Evidence:
    """Everything a diagnosis gathered (:meth:`triplanar.workbench.diagnose.Diagnoser.fit`), before any verdict.

    The model (``user_base``: as given; ``base``: with the forward-selection effects ``refit`` at their values), the
    model as given against the data (``baseline``, its error overall and per load), the repeats' scatter and what
    noise and the specimen explain of it, the entries fitted (``ranked``: candidates and refits, best cross-validated
    error first), the entry examined (``best``, ``None`` when none explains) and its look-alikes, the residual in time
    and its shared bias before and after it, the deciding experiments and the combination tried."""

    user_base: ModelSpec
    base: ModelSpec
    refit: Mapping[str, Mapping[str, float]]
    folds: Sequence[Sequence[float]]
    baseline: list[TestDiscrepancy]
    baseline_error_mm: float
    baseline_by_load: Mapping[float, float]
    repeat_scatter_mm: float
    noise_mm: float
    noise_floor_mm: float
    expected_scatter_mm: float
    friction_scatter_deg: float
    ranked: Sequence[CandidateResult]
    time_domain: Mapping[str, Any]
    systematic: Mapping[str, Any]
    best: CandidateResult | None
    lookalikes: Sequence[CandidateResult]
    after: list[TestDiscrepancy] | None
    time_domain_after: Mapping[str, Any]
    growth_after: float
    systematic_after: Mapping[str, Any]
    experiments: Sequence[Mapping[str, Any]] = ()
    combination: Combination | None = None
    #: the trace difference (mm) every interval admits (``rules.IMPLEMENTATION_TOLERANCE_M``; 0: gathered before it)
    implementation_tolerance_mm: float = 0.0
    #: the audit of the given numbers, the specimen's and the instruments'
    #: (:func:`triplanar.workbench.given.audit_given`; empty: not audited)
    given_numbers: Sequence[GivenAudit] = ()
    #: the rigid-block test of the measured contact points (:func:`triplanar.workbench.rigidity.rigidity`; ``None``:
    #: gathered before it); the rules read it for which entry is examined, where forward selection starts, a
    #: contact point off the drawing and no ``high`` for physics alone on an instrument fault (``rules``)
    rigidity: RigidityResult | None = None
    #: the cause outside the library located as one extra force (:func:`triplanar.workbench.locate.locate`; ``None``:
    #: the verdict is neither ``outside_library`` nor ``high``, or gathered before it); one rule reads it: a library
    #: verdict is not ``high`` when the located force predicts the held-out loads as well (``rules._outside_force``)
    located: LocatedResult | None = None

    @property
    def candidates(self) -> list[CandidateResult]:
        return [r for r in self.ranked if r.kind == "candidate"]

    @property
    def refits(self) -> list[CandidateResult]:
        return [r for r in self.ranked if r.kind == "refit"]

    @property
    def held_out(self) -> bool:
        """Something was held out (two load levels or more)."""
        return len(self.folds) > 1

    @property
    def where(self) -> str:
        return "on held-out loads" if self.held_out else "in sample (one load level: nothing held out)"

    @property
    def error_word(self) -> str:
        return "held-out error" if self.held_out else "in-sample error"


def label(c: CandidateResult) -> str:
    """An entry's name in the report (a refit marked ``(refit)``)."""
    return f"{c.effect}{' (refit)' if c.kind == 'refit' else ''}"


def shown_after(ev: Evidence, verdict: Verdict) -> tuple[list[TestDiscrepancy] | None, Mapping[str, Any], float,
                                                         str | None]:
    """The residual the report shows after the named model: ``(discrepancies, time domain, growth, label)`` (the
    combination's when the verdict names it, else the best single entry's)."""
    comb = ev.combination
    if verdict.kind is VerdictKind.LIBRARY_EFFECTS and comb is not None:
        return comb.after, comb.time_domain_after, comb.growth_after, "+ " + " + ".join(
            e.effect for e in verdict.effects)
    if ev.best is None:
        return None, ev.time_domain_after, ev.growth_after, None
    return ev.after, ev.time_domain_after, ev.growth_after, \
        f"{'refitted ' if ev.best.kind == 'refit' else '+ '}{ev.best.effect}"


def missing_kind(verdict: Verdict) -> str | None:
    """``"physics"``, ``"instrument"`` or ``"instrument and physics"``: what the named entries act on."""
    from ..effects import REGISTRY
    names = [e.effect for e in verdict.effects] or ([verdict.missing_effect] if verdict.missing_effect else [])
    kinds = sorted({REGISTRY[n].acts_on for n in names if n in REGISTRY})
    return " and ".join(kinds) if kinds else None


def report_json(ev: Evidence, verdict: Verdict, seconds: float) -> dict[str, Any]:
    """The JSON report (``diagnose.json``; fields in ``docs/workbench.md``): a view of ``verdict`` and ``ev``."""
    def finite(v: float | None) -> float | None:
        return v if v is not None and math.isfinite(v) else None

    _, td_after, _, _ = shown_after(ev, verdict)
    return {"verdict": verdict.kind.value,
            "missing_effect": verdict.missing_effect,
            "missing_effects": [e.as_json() for e in verdict.effects],
            "missing_kind": missing_kind(verdict),
            "indistinguishable_from": [label(c) for c in ev.lookalikes] if ev.best else [],
            "lookalike_groups": [dict(g) for g in verdict.groups],
            "given_numbers": [a.as_json() for a in ev.given_numbers],
            "rigidity": None if ev.rigidity is None else ev.rigidity.as_json(),
            "located": ev.located.as_json() if ev.located is not None and (
                verdict.kind is VerdictKind.OUTSIDE_LIBRARY or any(r.rule == "located.outside_force"
                                                                   for r in verdict.reasons)) else None,
            "systematic": {"model_as_given": dict(ev.systematic), "after_best": dict(ev.systematic_after)},
            "combination": None if verdict.combination is None else dict(verdict.combination),
            "deciding_experiments": [dict(e) for e in ev.experiments],
            "confidence": verdict.confidence,
            "reason": verdict.reason,
            "reasons": [r.as_json() for r in verdict.reasons],
            "wrong_given": [w for e in verdict.effects for w in e.wrong_given()],
            "baseline_error_mm": ev.baseline_error_mm,
            "candidates": [c.as_json() for c in ev.candidates],
            "refit_results": [c.as_json() for c in ev.refits],
            "refits": [{"effect": r.effect, "param": p, "given": r.given.get(p), "fitted": r.params[p],
                        "ci95": r.param_ci95.get(p), "status": r.param_status.get(p),
                        "cv_error_mm": r.cv_error_mm, "improvement": r.improvement}
                       for r in ev.refits for p in r.params],
            "noise": {"instrument_noise_mm": finite(ev.noise_mm),
                      "noise_floor_mm": finite(ev.noise_floor_mm),
                      "expected_scatter_mm": finite(ev.expected_scatter_mm),
                      "friction_scatter_deg": ev.friction_scatter_deg,
                      "repeat_scatter_mm": finite(ev.repeat_scatter_mm),
                      "unexplained_error_mm": finite(verdict.unexplained_mm)},
            "time_domain": {**ev.time_domain, "after_best": dict(td_after)},
            "repeat_scatter_mm": finite(ev.repeat_scatter_mm),
            "baseline_error_by_load_mm": {f"{k:g}": v for k, v in ev.baseline_by_load.items()},
            "model": ev.base.describe(),
            "folds_N": [[float(f) for f in fold] for fold in ev.folds],
            "cross_validated": ev.held_out,
            "n_tests": len(ev.baseline),
            "seconds": round(seconds, 2)}
