"""The verdict of a diagnosis: which entry is named, with what confidence and why, and the JSON report.

Deciding (the thresholds are attributes of :class:`~triplanar.workbench.diagnose.Diagnoser`):

* ``repeat_scatter_mm``: the discrepancy a perfect model would still show (repeats' spread about their mean
  path, :func:`~triplanar.workbench.discrepancy.repeat_scatter_mm`).
* Nothing to explain: baseline error below ``quiet_factor`` x scatter (and no bias common to all tests that an
  entry removes) -> ``none_missing``, or ``outside_library`` when the residual shows a pattern.
* An entry *explains* the data when its improvement (fraction of the baseline error removed, cross-validated) is
  at least ``min_improvement`` and none of its parameters ends at the edge of its plausible range; of those, the
  one-standard-error rule names the simplest that fits as well as the best (:mod:`~triplanar.workbench.parsimony`).
* Confidence ``high`` when, in addition, its improvement is at least ``high_improvement``, its cross-validated error
  is within ``explained_factor`` x scatter (what is left looks like repeat scatter), the runner-up's cross-validated
  error is at least ``margin`` x the winner's and worse by more than the uncertainty of the difference, no
  look-alike is known, no pattern or hint of a shared bias remains, and something was held out. Otherwise ``low``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from ..effects import REGISTRY
from .alternatives import moved_outside
from .evidence import HINT_ALPHA
from .parsimony import difference_se

if TYPE_CHECKING:
    from .diagnose import Diagnoser
    from .sweep import CandidateResult


def _fmt(values: Mapping[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in values.items())


def residual_kinds(diag: Diagnoser, unexplained_mm: float) -> list[str]:
    """What kind of residual remains (the evidence of an ``outside_library`` verdict)."""
    kinds = []
    td = diag.time_domain_after_
    if td.get("dominant_frequency_hz") is not None:
        kinds.append(f"periodic at {td['dominant_frequency_hz']:.1f} Hz (a spectral peak in "
                     f"{td['periodic_fraction']:.0%} of the tests)")
    if math.isfinite(diag.growth_after_) and diag.growth_after_ > 2.0:
        kinds.append(f"growing with travel (the lateral error over the last third of the travel is "
                     f"{diag.growth_after_:.1f} x that over the first)")
    scatter, expected = diag.repeat_scatter_mm_, diag.expected_scatter_mm_
    if math.isfinite(scatter) and math.isfinite(expected) and scatter > diag.scatter_factor * expected:
        kinds.append(f"random from test to test (the repeats scatter {scatter:.2f} mm, {scatter / expected:.1f} x "
                     f"the {expected:.2f} mm that instrument noise ({diag.noise_mm_:.2f} mm) and a "
                     f"{diag.friction_scatter_deg:g} deg friction scatter explain)")
    bias = diag.systematic_after_
    if bias["systematic"]:
        kinds.append(f"systematic, common to all tests (the {bias['feature']} averages {bias['mean']:+.3g} over "
                     f"the {bias['levels']} load levels, {abs(bias['z']):.1f} standard errors of the repeats' "
                     f"means from 0; p = {bias['p_value_all']:.2g})")
    if td.get("mostly_in_time"):
        kinds.append(f"mostly in time (travel lag {td['lag_rms_mm']:.2f} mm RMS against a mean path distance "
                     f"of {td['mean_distance_mm']:.2f} mm)")
    if not kinds and math.isfinite(unexplained_mm):
        kinds.append(f"{unexplained_mm:.2f} mm unexplained, without a periodic or travel-growing pattern")
    return kinds

@dataclass
class Judgement:
    """What the named entry's confidence and verdict rest on (:func:`judge`)."""

    scatter: float              # the scatter what it leaves is judged against
    scatter_ok: bool            # the repeats scatter no more than noise and the specimen explain
    periodic: bool
    systematic: bool            # a bias common to all tests remains after it
    explained: bool             # what it leaves is within the scatter
    separated: bool             # the runner-up is worse by the margin and the uncertainty; no look-alike
    hinted: bool                # a hint (p < HINT_ALPHA) of a shared bias remains
    high: bool
    runner: CandidateResult | None
    moved: list[dict[str, Any]]  # alternatives that move a named parameter outside its interval (alternatives.py)


def decide(diag: Diagnoser) -> None:
    """Set ``diag``'s verdict, missing effect, confidence, reason and unexplained error (the module's rules)."""
    diag.missing_effect_, diag.confidence_, diag.verdict_ = None, "none", "outside_library"
    if _nothing_to_explain(diag):
        return
    best = diag.best_
    base = diag.baseline_error_mm_
    if best is None:
        diag.unexplained_mm_ = base
        top = diag.ranked_[0] if diag.ranked_ else None
        detail = (f"; the best, {top.effect}, removes {top.improvement:.0%} of the error"
                  f"{'' if top.plausible else ' with an implausible ' + ', '.join(top.at_bound)}"
                  if top else "")
        diag.reason_ = (f"no candidate explains the discrepancy (none removes at least "
                        f"{diag.min_improvement:.0%} of it with plausible parameters){detail}; what remains: "
                        + "; ".join(residual_kinds(diag, base)))
        return
    diag.unexplained_mm_ = best.cv_error_mm
    j = judge(diag, best)
    diag.confidence_ = "high" if j.high else "low"
    why = _why(diag, best, j)
    if j.explained and j.scatter_ok and not j.periodic:
        diag.verdict_ = "refit_given_effect" if best.kind == "refit" else "library_effect"
        if best.kind == "candidate":
            diag.missing_effect_ = best.effect
    else:
        # a library effect helps, but what it leaves is not noise: say so rather than name it as the answer
        diag.verdict_ = "outside_library"
        diag.missing_effect_ = best.effect if best.kind == "candidate" else None
        why.append("but what remains is not noise: " + "; ".join(residual_kinds(diag, best.cv_error_mm)))
    if not j.high:
        why.append("low confidence: " + "; ".join(lacks(diag, best, j.systematic, j.explained, j.separated,
                                                             j.scatter_ok and not j.periodic, j.hinted, j.moved)))
    diag.reason_ = "; ".join(why)


def _scatter_ok(diag: Diagnoser) -> bool:
    scatter, expected = diag.repeat_scatter_mm_, diag.expected_scatter_mm_
    return not (math.isfinite(scatter) and math.isfinite(expected) and scatter > diag.scatter_factor * expected)


def _nothing_to_explain(diag: Diagnoser) -> bool:
    """The model as given is within the repeats' scatter (and no entry explains a shared bias below it): set the
    verdict (``none_missing``, or ``outside_library`` when the residual has a pattern) and return True."""
    scatter, expected, base = diag.repeat_scatter_mm_, diag.expected_scatter_mm_, diag.baseline_error_mm_
    # a candidate with per-test parameters that brings the error down to what noise and the specimen explain
    # explains the repeats' excess scatter itself: it is judged below even when the error is within that scatter
    per_test_explains = (diag.best_ is not None and bool(diag.best_.per_test) and math.isfinite(expected)
                         and diag.best_.fit_error_mm <= diag.scatter_factor * expected)
    hidden_bias = diag.systematic_["systematic"] and diag.best_ is not None   # below the scatter, but shared
    if not (math.isfinite(scatter) and base <= diag.quiet_factor * scatter) or per_test_explains or hidden_bias:
        return False
    diag.unexplained_mm_ = base
    periodic = diag.time_domain_after_.get("dominant_frequency_hz") is not None
    if _scatter_ok(diag) and not periodic and not diag.systematic_after_["systematic"]:
        diag.verdict_ = "none_missing"
        diag.reason_ = (f"the model already matches the data to within the repeats' own scatter (error "
                        f"{base:.2f} mm, scatter {scatter:.2f} mm), and that scatter is what instrument "
                        f"noise and the specimen's variability explain ({expected:.2f} mm): nothing is missing")
    else:
        diag.reason_ = (f"the model matches the data as well as the repeats agree with each other (error "
                        f"{base:.2f} mm, scatter {scatter:.2f} mm), but something outside the library acts: "
                        + "; ".join(residual_kinds(diag, base)))
    return True


def judge(diag: Diagnoser, best: CandidateResult) -> Judgement:
    """The evidence for the named entry ``best``: what it leaves against the scatter, the runner-up and look-alikes,
    the residual's patterns; ``high`` when all of it holds."""
    scatter, expected = diag.repeat_scatter_mm_, diag.expected_scatter_mm_
    scatter_ok = _scatter_ok(diag)
    periodic = diag.time_domain_after_.get("dominant_frequency_hz") is not None
    systematic = diag.systematic_after_["systematic"]
    others = [c for c in diag.ranked_ if c is not best]
    runner = others[0] if others else None
    if best.per_test and math.isfinite(expected):
        # per-test parameters explain test-to-test differences: what they leave is judged against what noise
        # and the specimen explain, not against the repeats' scatter (which they are meant to absorb)
        scatter = min(scatter, expected) if math.isfinite(scatter) else expected
        scatter_ok = best.fit_error_mm <= diag.scatter_factor * expected
    explained = ((not math.isfinite(scatter)) or best.cv_error_mm <= diag.explained_factor * scatter) \
        and not systematic
    diff, diff_se = difference_se(best, runner) if runner is not None else (math.nan, math.nan)
    # the runner-up must be worse by the margin and by more than the uncertainty of the difference, and no
    # entry may be within that uncertainty of the one named (a look-alike)
    separated = runner is None or not math.isfinite(runner.cv_error_mm) or (
        runner.cv_error_mm >= diag.margin * best.cv_error_mm and not (math.isfinite(diff) and diff <= diff_se)
        and not diag.lookalikes_)
    hinted = not systematic and diag.systematic_after_["p_value_all"] < HINT_ALPHA
    held_out = len(diag.folds_) > 1     # one load level: nothing was held out, nothing was judged out of sample
    moved = moved_outside(best)
    high = (best.improvement >= diag.high_improvement and explained and separated and scatter_ok and not periodic
            and not hinted and held_out and not moved)
    return Judgement(scatter, scatter_ok, periodic, systematic, explained, separated, hinted, high, runner, moved)


def _why(diag: Diagnoser, best: CandidateResult, j: Judgement) -> list[str]:
    """The reason's clauses for a named entry (before the verdict's own)."""
    expected, base = diag.expected_scatter_mm_, diag.baseline_error_mm_
    what = (f"refitting the given {best.effect} ({_fmt(best.given)} -> {_fmt(best.params)})"
            if best.kind == "refit" else best.effect)
    why = [f"{what} removes {best.improvement:.0%} of the error {diag.where_}"]
    if math.isfinite(j.scatter):
        if best.per_test and math.isfinite(expected):
            why.append(f"leaving {best.cv_error_mm:.2f} mm against the {expected:.2f} mm that noise and the "
                       f"specimen explain (its per-test {', '.join(best.per_test)} absorb the repeats' scatter of "
                       f"{diag.repeat_scatter_mm_:.2f} mm)")
        else:
            why.append(f"leaving {best.cv_error_mm:.2f} mm against a repeat scatter of {j.scatter:.2f} mm")
    top = diag.ranked_[0]
    if best is not top:
        why.append(f"{_label(best)} ({len(best.params)} free parameter(s)) is named over {top.effect} "
                   f"({len(top.params)}), whose {diag.error_word_} {top.cv_error_mm:.3f} mm is lower by less than "
                   f"the uncertainty of the difference (one-standard-error rule)")
    if diag.lookalikes_:
        why.append("the data cannot tell it from " + ", ".join(
            f"{_label(c)} ({diag.error_word_} {c.cv_error_mm:.3f} mm)" for c in diag.lookalikes_)
            + ": within the uncertainty of the difference")
    if j.runner is not None:
        why.append(f"runner-up {_label(j.runner)} leaves {j.runner.cv_error_mm:.2f} mm")
    if diag.time_domain_.get("mostly_in_time"):
        why.append(f"the model's error was mostly in time (travel lag {diag.time_domain_['lag_rms_mm']:.2f} mm "
                   f"RMS, mean path distance {diag.time_domain_['mean_distance_mm']:.2f} mm)")
    hidden_bias = diag.systematic_["systematic"]
    if hidden_bias and not j.systematic and math.isfinite(j.scatter) and base <= diag.quiet_factor * j.scatter:
        why.append(f"the model as given left a bias common to all tests below the scatter "
                   f"({diag.systematic_['feature']}, p = {diag.systematic_['p_value_all']:.2g}) that it removes")
    return why


def _label(c: CandidateResult) -> str:
    return f"{c.effect}{' (refit)' if c.kind == 'refit' else ''}"


def lacks(diag: Diagnoser, best: CandidateResult, systematic: bool, explained: bool, separated: bool, clean: bool,
           hinted: bool, moved: list[dict[str, Any]] | None = None) -> list[str]:
    """Why the confidence is not ``high``."""
    lacks = []
    if best.improvement < diag.high_improvement:
        lacks.append(f"it removes less than {diag.high_improvement:.0%}")
    if systematic:
        lacks.append("a bias common to all tests remains")
    elif not explained:
        lacks.append("what remains is well above the repeat scatter (another effect may be missing)")
    if not separated:
        lacks.append("a look-alike explains the data as well" if diag.lookalikes_ else
                     "the runner-up explains the data almost as well")
    if not clean:
        lacks.append("the residual shows a pattern no library effect explains")
    if len(diag.folds_) < 2:
        lacks.append("with one load level nothing was held out")
    if hinted:
        bias = diag.systematic_after_
        lacks.append(f"a hint of a bias common to all tests remains ({bias['feature']}, p = "
                     f"{bias['p_value_all']:.2g}): an unmodelled effect may have shifted the parameters")
    for m in moved or []:
        lacks.append(f"the value depends on the model's form: with {m['alternative']} fitted too, {m['param']} = "
                     f"{m['value']:.4g}, outside [{m['ci95'][0]:.4g}, {m['ci95'][1]:.4g}]")
    return lacks

def missing_kind(diag: Diagnoser) -> str | None:
    """``"physics"``, ``"instrument"`` or ``"physics and instrument"``: what the named entries act on."""
    names = [m["effect"] for m in diag.missing_effects_] or ([diag.missing_effect_] if diag.missing_effect_ else [])
    kinds = sorted({REGISTRY[n].acts_on for n in names if n in REGISTRY})
    return " and ".join(kinds) if kinds else None

def single_missing(diag: Diagnoser) -> list[dict[str, Any]]:
    """``missing_effects`` of a one-entry verdict (the named candidate, or the refit)."""
    best = diag.best_
    if best is None or diag.verdict_ not in ("library_effect", "refit_given_effect"):
        return []
    return [{"effect": best.effect, "kind": best.kind, "params": dict(best.params),
             "param_ci95": dict(best.param_ci95),
             **({"param_profile_ci95": dict(best.param_profile_ci95)} if best.param_profile_ci95 else {}),
             **({"param_model_ci95": dict(best.param_model_ci95)} if best.param_model_ci95 else {}),
             "cv_error_mm": best.cv_error_mm,
             "share_of_improvement": best.improvement, "confidence": diag.confidence_}]

def report(diag: Diagnoser) -> dict[str, Any]:
    def finite(v: float | None) -> float | None:
        return v if v is not None and math.isfinite(v) else None

    return {"verdict": diag.verdict_,
            "missing_effect": diag.missing_effect_,
            "missing_effects": diag.missing_effects_,
            "missing_kind": diag.missing_kind(),
            "indistinguishable_from": [f"{c.effect}{' (refit)' if c.kind == 'refit' else ''}"
                                       for c in getattr(diag, "lookalikes_", [])] if diag.best_ else [],
            "systematic": {"model_as_given": diag.systematic_, "after_best": diag.systematic_after_},
            "combination": diag.combination_,
            "deciding_experiments": diag.experiments_,
            "confidence": diag.confidence_,
            "reason": diag.reason_,
            "baseline_error_mm": diag.baseline_error_mm_,
            "candidates": [c.as_json() for c in diag.candidates_],
            "refit_results": [c.as_json() for c in diag.refits_],
            "refits": [{"effect": r.effect, "param": p, "given": r.given.get(p), "fitted": r.params[p],
                        "ci95": r.param_ci95.get(p), "status": r.param_status.get(p),
                        "cv_error_mm": r.cv_error_mm, "improvement": r.improvement}
                       for r in diag.refits_ for p in r.params],
            "noise": {"instrument_noise_mm": finite(diag.noise_mm_),
                      "noise_floor_mm": finite(diag.noise_floor_mm_),
                      "expected_scatter_mm": finite(diag.expected_scatter_mm_),
                      "friction_scatter_deg": diag.friction_scatter_deg,
                      "repeat_scatter_mm": finite(diag.repeat_scatter_mm_),
                      "unexplained_error_mm": finite(diag.unexplained_mm_)},
            "time_domain": {**diag.time_domain_, "after_best": diag.time_domain_after_},
            "repeat_scatter_mm": finite(diag.repeat_scatter_mm_),
            "baseline_error_by_load_mm": {f"{k:g}": v for k, v in diag.baseline_by_load_.items()},
            "model": diag.base_.describe(),
            "folds_N": [[float(f) for f in fold] for fold in diag.folds_],
            "cross_validated": len(diag.folds_) > 1,
            "n_tests": len(diag.baseline_),
            "seconds": round(diag.seconds_, 2)}
