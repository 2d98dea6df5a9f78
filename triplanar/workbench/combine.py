"""Combinations: when the best single entry leaves a pattern, add entries one at a time.

A diagnosis whose best explaining entry leaves a pattern (more than the scatter, a periodic or shared residual) may be
looking at two library effects at once (end friction and a tip offset, say): each alone bends the paths part of the
way. This module continues such a diagnosis as cross-validated forward selection: the best entry is kept (its
parameters refitted jointly with every later addition, as :class:`~triplanar.workbench.select.ForwardSelection`
does), the remaining candidates are diagnosed against the model with it, and so on (once a second entry has joined,
the first is re-examined given the second: :func:`_first_reexamined`); the rules of
:mod:`~triplanar.workbench.rules` say when to look further (:func:`~triplanar.workbench.rules.combination_continues`)
and which entry joins (:func:`~triplanar.workbench.rules.step_accepted`). It also runs from a close runner-up
(:func:`_close_runner_up`) and from the entry the rigid block's test points at
(:func:`~triplanar.workbench.rules.rigidity_start`; with no entry examined, from it alone), and keeps the better
combination.

Each step records its entry, its parameters with 95 % intervals *from the final joint fit*, its own share of the
improvement (``(cv error before it - cv error after it) / baseline error``: the shares add up to the total
improvement), its runner-up and its look-alikes (the verdict judges each step's confidence from them). An entry
refitted jointly in a later round keeps the model-form allowance of its own round (:func:`_own_allowance`), which
the joint fit's interval lacks. A refit of an
effect the user gave may be the first step; it is then held at its refitted values in later rounds (only added
candidates are refitted jointly). The result is evidence (a :class:`~triplanar.workbench.verdict.Combination`); the
verdict on it is :func:`~triplanar.workbench.rules.decide`'s.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any, Mapping, Protocol, Sequence

from ..effects import REGISTRY
from ..measurement import MeasuredTest
from . import rules
from .candidates import resolve, without_effect
from .evidence import growth_along_travel, systematic_bias, time_domain
from .intervals import form_allowance
from .parsimony import lookalikes_of, parsimonious
from .spec import spec_with_values
from .sweep import residual_of, spec_of
from .verdict import Combination, Evidence

if TYPE_CHECKING:
    from .candidate_result import CandidateResult
    from .spec import ModelSpec


class Diagnoser(Protocol):
    """What forward selection needs of a diagnoser (:class:`~triplanar.workbench.diagnose.Diagnoser` is one): its
    candidate list, and a diagnoser for a further round whose ``fit`` leaves that round's evidence in ``evidence_``.
    A protocol, so that the diagnoser, which calls :func:`combine`, and this module do not import each other."""

    candidates: Any
    evidence_: Evidence

    def next_round(self) -> Diagnoser: ...

    def fit(self, tests: Sequence[MeasuredTest], base: ModelSpec | None = None,
            refit: Mapping[str, Mapping[str, float]] | None = None) -> Diagnoser: ...


def _step(result: CandidateResult, ranked: Sequence[CandidateResult], before_mm: float, baseline_mm: float,
          look: Sequence[CandidateResult]) -> dict[str, Any]:
    """A step of the combination: ``result`` chosen in a round that ranked ``ranked`` (its runner-up: the best other
    entry there), taking the cross-validated error from ``before_mm``."""
    runner = next((c for c in ranked if c.key != result.key), None)
    return {"effect": result.effect, "kind": result.kind, "cv_error_mm": result.cv_error_mm,
            "share_of_improvement": (before_mm - result.cv_error_mm) / baseline_mm if baseline_mm > 0 else 0.0,
            "runner_up": None if runner is None else runner.effect,
            "runner_up_cv_error_mm": None if runner is None else runner.cv_error_mm,
            "indistinguishable_from": [c.effect for c in look]}


def combine(diag: Diagnoser, ev: Evidence, tests: Sequence[MeasuredTest]) -> Combination:
    """Forward selection from ``ev``'s examined entry (module doc), each round diagnosed by ``diag``'s
    :meth:`~triplanar.workbench.diagnose.Diagnoser.next_round`; every step has its ``params`` and ``param_ci95``
    from the last joint fit."""
    start = rules.rigidity_start(ev)
    first = ev.best if ev.best is not None else start
    assert first is not None
    base = ev.user_base
    if first.kind == "refit":      # the refitted given effect stays at its refitted values from here on
        base = spec_with_values(replace(base, effects=without_effect(base.effects, first.effect)), first.effect,
                                first.params)
    steps, results, baselines = _forward(diag, ev, tests, base, first, ev.lookalikes if ev.best else ())
    runner = _close_runner_up(ev, first) if ev.best is not None else None
    others = [runner] if runner is not None and len(results) >= 2 else []
    if start is not None and start is not first:        # rules.rigidity_start: the entry the rigid block points at
        others.append(start)
    for other in others:
        alt_steps, alt_results, alt_baselines = _forward(diag, ev, tests, base, other, lookalikes_of(other, ev.ranked))
        if len(alt_results) >= 2 and rules.swap_accepted(alt_results[-1], results[-1]):
            steps, results, baselines = alt_steps, alt_results, alt_baselines
            steps[0]["instead_of"] = first.effect
    final = results[-1]
    for i, step in enumerate(steps):
        name = step["effect"]
        if name in final.all_values and (len(results) > 1 or step["kind"] == "candidate"):
            step["params"] = {k: v for k, v in final.all_values[name].items() if k in final.all_ci95.get(name, {})}
            step["param_ci95"] = final.all_ci95.get(name, {})
            if i < len(results) - 1 and step["kind"] == "candidate":    # refitted jointly since its own round
                step["form_allowance"] = _own_allowance(results[i], baselines[i])
                step["param_ci95"] = _widened(step["param_ci95"], name, step["form_allowance"])
        else:                                   # a refitted given effect, held since its own round
            step["params"], step["param_ci95"] = dict(first.params), dict(first.param_ci95)
        if step["kind"] == "refit":
            step["given"] = dict(first.given)
    if len(results) == 1:                   # no entry joined
        after, spec = ev.after, None
    else:
        after, spec = residual_of(base, final, tests), spec_of(base, final)
    td = time_domain(after) if after is not None else dict(ev.time_domain_after)
    gain, gain_se = rules.beats(final, first)
    return Combination(tuple(steps), final.cv_error_mm, td.get("dominant_frequency_hz") is not None,
                       bool(systematic_bias(after)["systematic"]) if after is not None else False, spec, after, td,
                       growth_along_travel(after) if after is not None else ev.growth_after, gain, gain_se,
                       dict(final.held_out_mm))


Selection = tuple[list[dict[str, Any]], list["CandidateResult"], list[float]]


def _forward(diag: Diagnoser, ev: Evidence, tests: Sequence[MeasuredTest], base: ModelSpec, first: CandidateResult,
             look: Sequence[CandidateResult]) -> Selection:
    """Forward selection from the single entry ``first`` (``look``: its look-alikes): ``(steps, results, each round's
    baseline)``, the rounds' entries in order (a pair's first re-examined once the second joins)."""
    added = {} if first.kind == "refit" else {first.effect: dict(first.all_values[first.effect])}
    steps = [_step(first, ev.ranked, ev.baseline_error_mm, ev.baseline_error_mm, look)]
    results = [first]
    baselines = [ev.baseline_error_mm]          # each round's baseline (the entries so far), for _own_allowance
    while rules.combination_continues(results[-1].cv_error_mm, ev.repeat_scatter_mm, len(steps)):
        if not resolve(diag.candidates, exclude=(*base.effect_names, *added), specimen=base.specimen):
            break                              # every candidate is in already (a short candidate list)
        nxt = diag.next_round().fit(tests, base, refit=added or None)
        best, look_best = _round_choice(nxt.evidence_.ranked)
        if best is None or not rules.step_accepted(best, results[-1]):
            break
        steps.append(_step(best, nxt.evidence_.ranked, results[-1].cv_error_mm, ev.baseline_error_mm, look_best))
        results.append(best)
        baselines.append(nxt.evidence_.baseline_error_mm)
        if len(results) == 2 and first.kind == "candidate":
            swapped = _first_reexamined(diag, ev, tests, base, first, best)
            if swapped is not None:
                steps, results, baselines = swapped
        added = {k: dict(v) for k, v in results[-1].all_values.items()}
    return steps, results, baselines


def _round_choice(ranked: Sequence[CandidateResult]) -> tuple[CandidateResult | None, list[CandidateResult]]:
    """A round's entry and its look-alikes: the one-standard-error rule over its plausible entries (the round's own
    examined entry judges improvement against its baseline, the in-sample fit of the entries so far; here an entry is
    judged against their cross-validated error)."""
    plausible = [c for c in ranked if c.plausible]
    return parsimonious(plausible) if plausible else (None, [])


def _close_runner_up(ev: Evidence, first: CandidateResult) -> CandidateResult | None:
    """The best other plausible single entry when it comes within ``MARGIN`` of ``first``
    (:func:`~triplanar.workbench.rules.restart_from`): forward selection is then also run from it, and the better
    combination kept. Why: the first step decides the path, and when it was not decisive the path from the close
    runner-up may be the pair (on the calibration set: rate friction first, the actuator's rise within 1.14 x, for a
    tip offset with an actuator's rise, s4051)."""
    if first.kind != "candidate":
        return None
    others = [c for c in ev.ranked if c.key != first.key and c.plausible and c.kind == "candidate" and not c.per_test]
    return others[0] if others and rules.restart_from(first, others[0]) else None


def _first_reexamined(diag: Diagnoser, ev: Evidence, tests: Sequence[MeasuredTest], base: ModelSpec,
                      a: CandidateResult, pair: CandidateResult) -> Selection | None:
    """Stepwise selection's backward look (Efroymson's stepwise regression): with a pair [A, B] found, the first
    entry A is re-examined given the second: the candidates are ranked against the model with B alone, and when
    another entry C beats the pair (:func:`~triplanar.workbench.rules.swap_accepted`), the combination is [B, C],
    B's step from the single round. Returns ``(steps, results, baselines)`` of [B, C], or None to keep [A, B].

    Why: forward selection keeps its first entry for good, and the best single entry of a pair's data can be a
    stand-in for both (a time offset for a tip offset with an actuator's rise): on the calibration set's tuning part
    that named the stand-in with the right second entry (s3022)."""
    second = pair.effect
    single = next((c for c in ev.ranked if c.effect == second and c.kind == "candidate" and c.plausible), None)
    if single is None:
        return None
    nxt = diag.next_round().fit(tests, base, refit={second: dict(pair.all_values[second])})
    best, look = _round_choice(nxt.evidence_.ranked)
    if best is None or best.effect == a.effect or not rules.swap_accepted(best, pair) \
            or not rules.step_accepted(best, single):
        return None
    steps = [_step(single, ev.ranked, ev.baseline_error_mm, ev.baseline_error_mm, lookalikes_of(single, ev.ranked)),
             _step(best, nxt.evidence_.ranked, single.cv_error_mm, ev.baseline_error_mm, look)]
    steps[1]["replaces"] = a.effect
    return steps, [single, best], [ev.baseline_error_mm, nxt.evidence_.baseline_error_mm]


def _own_allowance(entry: CandidateResult, baseline_mm: float) -> dict[str, float]:
    """``{param: allowance}``: the model-form allowance (:func:`~triplanar.workbench.intervals.form_allowance`,
    :func:`~triplanar.workbench.rules.form_tolerance_mm`) of ``entry``'s parameters at its own round, where its sensitivity is measured (the
    error it removed from that round's baseline per unit of its move from its start). A later round's joint fit
    cannot measure it (its baseline already holds the entry), so its interval for the entry lacks it; on the
    calibration's pairs that left the actuator rise's tau outside its interval (s1022, s2022, s2051)."""
    tolerance_mm = rules.form_tolerance_mm(entry.effect)
    return {k: form_allowance(p.value, p.start if p.start is not None else p.value, baseline_mm, entry.fit_error_mm,
                              tolerance_mm) for k, p in entry.parameters.items()}


def _widened(ci95: Mapping[str, Any], effect: str, allowance: Mapping[str, float]) -> dict[str, Any]:
    """``ci95`` with each interval's half-width grown by ``allowance`` (clipped to the parameter's physical bounds)."""
    out = dict(ci95)
    for k, ci in ci95.items():
        extra = allowance.get(k, 0.0)
        if ci is not None and extra > 0:
            par = REGISTRY[effect].parameters[k]
            out[k] = (max(par.lower, ci[0] - extra), min(par.upper, ci[1] + extra))
    return out
