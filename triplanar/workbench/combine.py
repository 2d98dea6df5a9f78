"""Verdicts over combinations: when no single entry explains the data, add entries one at a time.

A diagnosis whose best explaining entry leaves more than the repeats' scatter may be looking at two library
effects at once (end friction and a tip offset, say): each alone bends the paths part of the way. This module
continues such a diagnosis as cross-validated forward selection: the best entry is kept (its parameters
refitted jointly with every later addition, as :class:`~triplanar.workbench.select.ForwardSelection` does), the
remaining candidates are diagnosed against the model with it, and so on, until what is left is within the
scatter, nothing further explains at least ``min_fall`` of the current cross-validated error, or
``max_effects`` entries are in.

Each step records its entry, its parameters with 95 % intervals *from the final joint fit*, its own share of
the improvement (``(cv error before it - cv error after it) / baseline error``: the shares add up to the total
improvement), and a confidence: ``high`` when that round's runner-up left at least ``margin`` x its error, else
``low``. A refit of an effect the user gave may be the first step; it is then held at its refitted values in
later rounds (only added candidates are refitted jointly).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Sequence

from ..measurement import MeasuredTest
from .candidates import resolve, without_effect
from .parsimony import parsimonious
from .spec import spec_with_values

if TYPE_CHECKING:
    from .diagnose import CandidateResult, Diagnoser


def format_value(name: str, value: float, ci: Sequence[float] | None) -> str:
    """``name = value [low, high]`` (the one interval format of every command's output)."""
    return f"{name} = {value:.4g}" + (f" [{ci[0]:.4g}, {ci[1]:.4g}]" if ci is not None else "")


def _step(result: CandidateResult, runner: CandidateResult | None, before_mm: float, baseline_mm: float,
          margin: float) -> dict[str, Any]:
    separated = runner is None or not math.isfinite(runner.cv_error_mm) or \
        runner.cv_error_mm >= margin * result.cv_error_mm
    return {"effect": result.effect, "kind": result.kind, "cv_error_mm": result.cv_error_mm,
            "share_of_improvement": (before_mm - result.cv_error_mm) / baseline_mm if baseline_mm > 0 else 0.0,
            "runner_up": None if runner is None else runner.effect,
            "runner_up_cv_error_mm": None if runner is None else runner.cv_error_mm,
            "confidence": "high" if separated else "low"}


def combine(diag: Diagnoser, tests: Sequence[MeasuredTest], max_effects: int = 3,
            min_fall: float = 0.1) -> dict[str, Any]:
    """Forward selection from ``diag``'s best explaining entry (module doc). Returns ``{"steps": [...],
    "cv_error_mm", "explains", "periodic", "diagnoses"}``; every step has its ``params`` and ``param_ci95`` from
    the last joint fit."""
    first = diag.best_
    assert first is not None
    base = diag.user_base_
    added: dict[str, dict[str, float]] = {}
    if first.kind == "refit":      # the refitted given effect stays at its refitted values from here on
        base = spec_with_values(replace(base, effects=without_effect(base.effects, first.effect)), first.effect,
                                first.params)
    else:
        added[first.effect] = dict(first.all_values[first.effect])
    others = [c for c in diag.ranked_ if c is not first]
    steps = [_step(first, others[0] if others else None, diag.baseline_error_mm_, diag.baseline_error_mm_,
                   diag.margin)]
    steps[0]["indistinguishable_from"] = [c.effect for c in diag.lookalikes_]
    if diag.lookalikes_:
        steps[0]["confidence"] = "low"
    results = [first]
    last, rounds = diag, []
    while len(steps) < max_effects:
        current = results[-1].cv_error_mm
        if current <= diag.explained_factor * diag.repeat_scatter_mm_:
            break
        if not resolve(diag.candidates, exclude=(*base.effect_names, *added), specimen=base.specimen):
            break                              # every candidate is in already (a short candidate list)
        nxt = type(diag)(diag.candidates, diag.folds, diag.executor, False, diag.max_nfev, refit_given=False,
                         start=diag.start, combine=False,
                         model_form=False)
        nxt.friction_scatter_deg = diag.friction_scatter_deg
        nxt.fit(tests, base, refit=added or None)
        # the best plausible entry by cross-validated error (nxt.best_ judges improvement against nxt's baseline,
        # the in-sample fit of the entries so far; here it is judged against their cross-validated error)
        plausible = [c for c in nxt.ranked_ if c.plausible]
        best, look = parsimonious(plausible) if plausible else (None, [])
        if best is None or not math.isfinite(best.cv_error_mm) or best.cv_error_mm > (1 - min_fall) * current:
            break
        rest = [c for c in nxt.ranked_ if c is not best]
        steps.append(_step(best, rest[0] if rest else None, current, diag.baseline_error_mm_, diag.margin))
        steps[-1]["indistinguishable_from"] = [c.effect for c in look]
        if look:
            steps[-1]["confidence"] = "low"
        results.append(best)
        added = {k: dict(v) for k, v in best.all_values.items()}
        last = nxt
        rounds.append(nxt.report_)
    final = results[-1]
    for step in steps:
        name = step["effect"]
        if name in final.all_values and (final is not first or step["kind"] == "candidate"):
            step["params"] = {k: v for k, v in final.all_values[name].items() if k in final.all_ci95.get(name, {})}
            step["param_ci95"] = final.all_ci95.get(name, {})
        else:                                   # a refitted given effect, held since its own round
            step["params"], step["param_ci95"] = dict(first.params), dict(first.param_ci95)
    periodic = last.time_domain_after_.get("dominant_frequency_hz") is not None
    explains = final.cv_error_mm <= diag.explained_factor * diag.repeat_scatter_mm_ and not periodic
    return {"steps": steps, "cv_error_mm": final.cv_error_mm, "explains": explains, "periodic": periodic,
            "diagnoses": rounds, "final": final, "last": last}


def apply_combination(diag: Diagnoser, tests: Sequence[MeasuredTest]) -> None:
    """No single entry explains: try entries in combination (:func:`combine`) and, when they explain the data,
    give ``diag`` the verdict ``library_effects``; else add what the combination leaves to its reason."""
    comb = combine(diag, tests)
    steps = comb["steps"]
    diag.combination_ = {k: comb[k] for k in ("steps", "cv_error_mm", "explains", "periodic")}
    scatter, expected = diag.repeat_scatter_mm_, diag.expected_scatter_mm_
    scatter_ok = not (math.isfinite(expected) and scatter > diag.scatter_factor * expected)
    listed = "; then ".join(
        f"{'refitting the given ' if s['kind'] == 'refit' else ''}{s['effect']} ("
        + ", ".join(format_value(k, v, s["param_ci95"].get(k)) for k, v in s["params"].items())
        + f") removes {s['share_of_improvement']:.0%}" for s in steps)
    if len(steps) >= 2 and comb["explains"] and scatter_ok:
        diag.verdict_ = "library_effects"
        diag.combined_spec_ = comb["last"]._spec_of(comb["final"])
        diag.missing_effects_ = steps
        diag.missing_effect_ = next((s["effect"] for s in steps if s["kind"] == "candidate"), None)
        diag.confidence_ = "high" if all(s["confidence"] == "high" for s in steps) else "low"
        diag.unexplained_mm_ = comb["cv_error_mm"]
        last = comb["last"]
        diag.after_, diag.time_domain_after_ = last.after_, last.time_domain_after_
        diag.growth_after_ = last.growth_after_
        diag.best_label_ = "+ " + " + ".join(s["effect"] for s in steps)
        low = [f"{s['effect']} ({', '.join(s['indistinguishable_from'] or [str(s['runner_up'])])} "
               f"{'fits as well' if s['indistinguishable_from'] else 'comes close'})"
               for s in steps if s["confidence"] != "high"]
        diag.reason_ = (f"two or more library effects explain the discrepancy, none alone: {listed} of the error "
                        f"{diag.where_}; together they leave {comb['cv_error_mm']:.2f} mm against a repeat "
                        f"scatter of {scatter:.2f} mm"
                        + (f"; low confidence at the step of {'; '.join(low)}" if low else ""))
    elif len(steps) >= 2:
        diag.reason_ += (f"; in combination ({listed} of the error {diag.where_}) they still leave "
                         f"{comb['cv_error_mm']:.2f} mm" + (", periodic" if comb["periodic"] else ""))
