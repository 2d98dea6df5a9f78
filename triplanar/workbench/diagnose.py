"""Which effect is the model missing? Try each candidate, fit it, cross-validate by load level, rank.

For every candidate effect (:mod:`triplanar.workbench.candidates`) the :class:`Diagnoser` fits its
parameters with the effect added to the user's model, once per cross-validation fold (trained on the other
load levels, scored on the fold's levels) and once on all tests (the reported estimate). Folds are load
levels, interleaved (fold k holds levels k, k+K, k+2K, ... of the sorted loads), so a candidate is judged on
loads it was not fitted to: an effect that only memorises does not win. Candidates are ranked by
cross-validated RMS discrepancy (``cv_error_mm``).

Every (candidate, fold) fit is an independent :class:`~triplanar.workbench.fit.FitTask`, mapped with
:func:`~triplanar.workbench.fit.run_fit` over the executor: the sweep parallelises across processes (or a
cluster) without change.

Deciding (the thresholds are attributes of :class:`Diagnoser`):

* ``repeat_scatter_mm``: the discrepancy a perfect model would still show (repeats' spread about their mean
  path, :func:`~triplanar.workbench.discrepancy.repeat_scatter_mm`).
* Nothing to explain: baseline error below ``quiet_factor`` x scatter -> ``missing_effect`` null,
  confidence ``"none"``.
* A candidate *explains* the data when its improvement (fraction of the baseline error removed, cross-
  validated) is at least ``min_improvement`` and none of its parameters ends at the edge of its plausible
  range. The best explaining candidate is named; otherwise null / ``"none"``.
* Confidence ``"high"`` when, in addition, its improvement is at least ``high_improvement``, its cross-
  validated error is within ``explained_factor`` x scatter (what is left looks like repeat scatter), and the
  runner-up's cross-validated error is at least ``margin`` x the winner's (the data tell them apart).
  Otherwise ``"low"``.
* ``param_stderr``: the larger of the cluster-robust sandwich error of the full fit and the delete-a-fold
  jackknife over the cross-validation fits (which also sees a parameter drifting with load).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..measurement import MeasuredTest
from .candidates import Candidate, refit_candidate, resolve, without_effect
from .discrepancy import TestDiscrepancy, repeat_scatter_mm, rms
from .evidence import (HINT_ALPHA, expected_scatter_mm, growth_along_travel, instrument_noise_mm, noise_floor_mm,
                       systematic_bias, time_domain)
from .intervals import interval95
from .parsimony import difference_se, parsimonious
from .executor import ExecutorLike, TaskCheckpoint, run_tasks
from .fit import (FitOutcome, FitTask, discrepancies, errors_by_load, evaluate_spec, overall_error,
                  run_fit)
from .spec import ModelSpec, spec_with_values
from ..effects import REGISTRY
from dataclasses import replace


def load_folds(forces: Sequence[float], k: int) -> list[list[float]]:
    """Interleaved folds of the sorted load levels (at most one fold per level)."""
    levels = sorted(set(float(f) for f in forces))
    k = max(1, min(k, len(levels)))
    return [levels[i::k] for i in range(k)]


@dataclass
class CandidateResult:
    """One candidate's line of the report."""

    effect: str
    params: dict[str, float]
    param_stderr: dict[str, float]
    cv_error_mm: float
    fit_error_mm: float
    improvement: float
    plausible: bool
    at_bound: list[str]
    cv_error_by_load: dict[float, float] = field(default_factory=dict)
    fold_params: list[dict[str, float]] = field(default_factory=list)
    seconds: float = 0.0
    nfev: int = 0
    all_values: dict[str, dict[str, float]] = field(default_factory=dict)
    all_stderr: dict[str, dict[str, float]] = field(default_factory=dict)
    kind: str = "candidate"                       # "candidate" (added) or "refit" (a given effect, freed)
    given: dict[str, float] = field(default_factory=dict)   # refit: the values the user gave
    param_ci95: dict[str, list[float] | None] = field(default_factory=dict)
    param_status: dict[str, str] = field(default_factory=dict)
    fixed: dict[str, float] = field(default_factory=dict)
    per_test: dict[str, dict[str, Any]] = field(default_factory=dict)   # param -> summary (pertest.summarize)
    per_test_values: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict, repr=False)
    all_ci95: dict[str, dict[str, list[float] | None]] = field(default_factory=dict)   # every effect fitted with it
    held_out_mm: dict[str, float] = field(default_factory=dict, repr=False)   # test_id -> its error when held out
    bias_ratio: float = 1.0      # evidence.bias_ratio of the full fit (the intervals' model-form allowance)

    def as_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "params": self.params, "param_ci95": self.param_ci95,
                **({"per_test": self.per_test} if self.per_test else {}),
                "param_stderr": self.param_stderr,
                "cv_error_mm": self.cv_error_mm, "improvement": self.improvement, "kind": self.kind,
                "param_status": self.param_status, "fixed": self.fixed,
                **({"given": self.given} if self.kind == "refit" else {}),
                "fit_error_mm": self.fit_error_mm, "plausible": self.plausible, "at_bound": self.at_bound,
                "cv_error_by_load_mm": {f"{k:g}": v for k, v in self.cv_error_by_load.items()},
                "fold_params": self.fold_params, "fit_seconds": round(self.seconds, 3), "nfev": self.nfev,
                **({"refitted": {k: v for k, v in self.all_values.items() if k != self.effect}}
                   if len(self.all_values) > 1 else {})}


def _fmt(values: Mapping[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in values.items())


def _jackknife(folds: list[dict[str, float]]) -> dict[str, float]:
    k = len(folds)
    if k < 2:
        return {}
    out = {}
    for name in folds[0]:
        values = np.array([f[name] for f in folds])
        out[name] = float(math.sqrt((k - 1) / k * np.sum((values - values.mean()) ** 2)))
    return out


@dataclass(frozen=True)
class CandidateTask:
    """Everything one candidate's cross-validated fit needs (picklable: the unit of a diagnose sweep)."""

    base: ModelSpec
    candidate: Candidate
    tests: tuple[MeasuredTest, ...]
    folds: tuple[tuple[float, ...], ...]
    max_nfev: int = 30
    refit: tuple[Candidate, ...] = ()
    warm: Mapping[str, Mapping[str, float]] | None = None
    kind: str = "candidate"

    @property
    def key(self) -> str:
        return f"{self.kind}:{self.candidate.effect}"


def run_candidate(task: CandidateTask) -> dict[str, FitOutcome]:
    """Fit one candidate (jointly with the ``refit`` effects, warm-started at ``warm``) on all tests, then on
    each fold's training levels, scoring the fold's held-out levels; returns ``{"all": ..., "fold0": ...}``.
    Pure: the unit a diagnose sweep maps.

    The full fit starts from the candidate's grid scan (or its neutral start); each fold's fit starts from
    the full fit's optimum (a warm start: it converges in a few iterations; the fold's optimum itself depends
    only on its training levels), its Jacobian started from the full fit's last Jacobian rows of its training
    tests and updated by Broyden's secant rule along the steps (an iteration costs one evaluation instead of one
    per parameter more; the fold's residuals are its own, the Jacobian only steers). All fits share one
    evaluation cache (folds split by load level, so a level's tests are the same in every fit)."""
    cache: dict = {}
    cands = (task.candidate, *task.refit)
    tests = list(task.tests)
    out: dict[str, FitOutcome] = {}
    rows: dict = {}
    out["all"] = run_fit(FitTask(task.base, cands, tuple(tests), (), None, task.max_nfev, "all", task.warm),
                         map, cache, rows_out=rows)
    if not out["all"].per_test:     # the fitted model's residual means: the intervals' model-form allowance
        from .evidence import model_form_allowance
        spec = task.base
        for name, values in out["all"].values.items():
            spec = spec_with_values(spec, name, values)
        out["all"] = replace(out["all"], bias_ratio=model_form_allowance(discrepancies(evaluate_spec(spec, tests))))
    phis = None
    if out["all"].per_test:  # per-test parameters: each training test starts at its value in the full fit
        names = [(c.effect, p) for c in cands for p in c.per_test]
        phis = {t.test_id: tuple(out["all"].per_test[e][p][t.test_id] for e, p in names) for t in tests
                if all(t.test_id in out["all"].per_test[e][p] for e, p in names)}
    for i, fold in enumerate(task.folds):
        held = tuple(t for t in tests if t.shear_force_N in fold)
        train = tuple(t for t in tests if t.shear_force_N not in fold) or held  # one level only: in sample
        out[f"fold{i}"] = run_fit(FitTask(task.base, cands, train, held, out["all"].vector, task.max_nfev,
                                          f"fold{i}", phi_start=phis), map, cache, chord=rows or None)
    return out


class Diagnoser:
    """Find the effect a model lacks (scikit-learn style: configure, ``fit(tests)``, read attributes).

    Args:
        candidates: effect names or :class:`Candidate` recipes (default: every registered effect, minus
            those already in the model).
        folds: cross-validation folds over load levels (default 3; fewer if there are fewer levels).
        executor: ``None``/``"local"`` (2-process pool), ``"serial"``, ``"ray"``, or any object with ``map``.
        progress: show a progress bar (tqdm, on stderr).
        max_nfev: least-squares evaluations per fit.
        per_test: ``{effect: [param, ...]}``: candidate parameters fitted for each test (the others shared), in
            addition to those declared ``Parameter(per_test=True)`` (:mod:`~triplanar.workbench.pertest`); such a
            candidate's leftover error is judged against the scatter noise and the specimen explain.
        checkpoint: a :class:`TaskCheckpoint`: finished candidates are kept on disk, so that an interrupted
            diagnosis run again resumes instead of starting over (the ``diagnose`` command uses
            ``DIR/.diagnose-partial`` and removes it when done).

    Fitted attributes: ``report_`` (the JSON report), ``candidates_`` (list of :class:`CandidateResult`,
    best first), ``missing_effect_``, ``confidence_``, ``reason_``, ``baseline_error_mm_``,
    ``repeat_scatter_mm_``, ``baseline_`` (per-test discrepancies), ``seconds_``.
    """

    min_improvement = 0.3
    high_improvement = 0.5
    explained_factor = 2.0
    quiet_factor = 1.5
    margin = 1.25
    #: the repeat scatter may exceed what noise and the specimen's variability explain by this factor
    scatter_factor = 2.0
    #: the specimen's repeat-to-repeat friction scatter assumed by ``expected_scatter_mm`` (deg)
    friction_scatter_deg = 0.2

    def __init__(self, candidates: Sequence[str | Candidate] | None = None, folds: int = 3,
                 executor: ExecutorLike = None, progress: bool = True, max_nfev: int = 30,
                 checkpoint: TaskCheckpoint | None = None, refit_given: bool = True,
                 start: Mapping[str, Mapping[str, float]] | None = None,
                 per_test: Mapping[str, Sequence[str]] | None = None, combine: bool = True):
        self.combine = combine
        self.per_test = {k: list(v) for k, v in (per_test or {}).items()}
        self.checkpoint = checkpoint
        self.refit_given = refit_given
        self.start = {k: dict(v) for k, v in (start or {}).items()}
        if isinstance(folds, bool) or not isinstance(folds, int) or folds < 2:
            raise ValueError(f"folds = {folds!r}: cross-validation needs at least 2 folds")
        self.candidates = candidates
        self.folds = folds
        self.executor = executor
        self.progress = progress
        self.max_nfev = max_nfev

    def fit(self, tests: Sequence[MeasuredTest], base: ModelSpec | None = None,
            refit: Mapping[str, Mapping[str, float]] | None = None) -> Diagnoser:
        """Diagnose ``tests`` against ``base`` (default: case B, reference specimen).

        ``refit``: effects already added to the model, ``{name: {param: value}}``; they are part of the
        model being diagnosed, and their parameters are re-estimated jointly with each candidate's (what
        forward selection does)."""
        began = time.perf_counter()
        base = base or ModelSpec()
        tests = list(tests)
        if not tests:
            raise ValueError("diagnose needs at least one measured test")
        refit = {k: dict(v) for k, v in (refit or {}).items()}
        refit_cands = tuple(resolve(list(refit), specimen=base.specimen))
        cands = resolve(self.candidates, exclude=(*base.effect_names, *refit), specimen=base.specimen)
        # the user's given effects, each freed in turn (the others and any forward-selection refits kept)
        given = [(name, dict(values)) for name, values in base.effects if REGISTRY[name].parameters
                 and any(p.free for p in REGISTRY[name].parameters.values())] if self.refit_given else []
        cands = [self._with_start(c.with_per_test(self.per_test[c.effect]) if c.effect in self.per_test else c)
                 for c in cands]
        unknown = sorted(set(self.per_test) - {c.effect for c in cands})
        if unknown:
            raise ValueError(f"per-test parameters of {unknown[0]!r}: that effect is not a candidate")
        if not cands and not given:
            raise ValueError("no candidate effects to try (all are already in the model)")
        self.user_base_ = base
        self.refit_ = refit
        for name, values in refit.items():
            base = spec_with_values(base, name, values)
        self.base_ = base
        self.baseline_: list[TestDiscrepancy] = discrepancies(evaluate_spec(base, tests))
        self.baseline_error_mm_ = overall_error(self.baseline_)
        self.baseline_by_load_ = errors_by_load(self.baseline_)
        self.repeat_scatter_mm_ = repeat_scatter_mm(tests, base.rest_positions)
        folds = load_folds([t.shear_force_N for t in tests], self.folds)
        self.folds_ = folds
        # one load level: nothing can be held out, every error is in sample; the wording says so
        self.where_ = "on held-out loads" if len(folds) > 1 else "in sample (one load level: nothing held out)"
        self.error_word_ = "held-out error" if len(folds) > 1 else "in-sample error"
        tasks = [CandidateTask(self.user_base_, c, tuple(tests), tuple(tuple(f) for f in folds), self.max_nfev,
                               refit_cands, refit) for c in cands]
        for name, values in given:
            stripped = replace(self.user_base_, effects=without_effect(self.user_base_.effects, name))
            tasks.append(CandidateTask(stripped, refit_candidate(name, values, base.specimen), tuple(tests),
                                       tuple(tuple(f) for f in folds), self.max_nfev, refit_cands, refit,
                                       kind="refit"))
        # Slowest first (slow simulations, many parameters), so that the pool stays balanced.
        tasks.sort(key=lambda t: (t.candidate.effect != "actuator_rise", -len(t.candidate.free)))
        outcomes = run_tasks(run_candidate, tasks, self.executor, self.progress, desc="diagnose",
                             checkpoint=self.checkpoint)
        by_label = {f"{t.key}/{k}": v for t, out in zip(tasks, outcomes) for k, v in out.items()}
        results = [self._assemble(t, by_label, len(folds), len(tests)) for t in tasks]
        results.sort(key=lambda r: (not math.isfinite(r.cv_error_mm), r.cv_error_mm))
        self.candidates_ = [r for r in results if r.kind == "candidate"]
        self.refits_ = [r for r in results if r.kind == "refit"]
        self.ranked_ = results
        self.outcomes_ = by_label
        self._evidence(tests, base)
        self._decide()
        from .experiment import experiments_for
        self.experiments_ = experiments_for(self, tests)
        self.combination_: dict[str, Any] | None = None
        self.missing_effects_ = self._single_missing()
        best = self.best_
        if (self.combine and self.verdict_ == "outside_library" and best is not None and not best.per_test
                and math.isfinite(self.repeat_scatter_mm_)
                and best.cv_error_mm > self.explained_factor * self.repeat_scatter_mm_):
            from .combine import apply_combination
            apply_combination(self, tests)
        self.seconds_ = time.perf_counter() - began
        self.report_ = self._report()
        return self

    def _assemble(self, task: CandidateTask, by_label: dict[str, FitOutcome], k: int,
                  n_tests: int) -> CandidateResult:
        cand = task.candidate
        full = by_label[f"{task.key}/all"]
        held: dict[str, tuple[float, float]] = {}
        fold_params = []
        for i in range(k):
            out = by_label[f"{task.key}/fold{i}"]
            held.update(out.held_out_errors)
            fold_params.append({p: out.values[cand.effect][p] for p in cand.shared})
        cv = rms([e for _, e in held.values()])
        by_load: dict[float, list[float]] = {}
        for force, err in held.values():
            by_load.setdefault(force, []).append(err)
        params = {p: full.values[cand.effect][p] for p in cand.shared}
        sandwich = full.stderr.get(cand.effect, {})
        jack = _jackknife(fold_params) if k > 1 else {}
        stderr = {p: float(max(sandwich.get(p, 0.0), jack.get(p, 0.0))) for p in cand.shared}
        base = self.baseline_error_mm_
        improvement = 1.0 - cv / base if base > 0 and math.isfinite(cv) else 0.0
        implausible = [a.split(".", 1)[1] for a in full.at_bound if a.split(".", 1)[0] == cand.effect]
        seconds = full.seconds + sum(by_label[f"{task.key}/fold{i}"].seconds for i in range(k))
        nfev = full.nfev + sum(by_label[f"{task.key}/fold{i}"].nfev for i in range(k))
        start = cand.start_values()
        ci, status = {}, {}
        for p in cand.shared:
            lo, hi = REGISTRY[cand.effect].parameters[p].lower, REGISTRY[cand.effect].parameters[p].upper
            ci[p], status[p] = interval95(params[p], sandwich.get(p, math.nan), jack.get(p, 0.0), n_tests,
                                          len(cand.shared), full.train_error_mm, self.repeat_scatter_mm_,
                                          (lo, hi), start[p], cand.bounds[p], full.bias_ratio)
            if p in implausible and ci[p] is not None:   # (without an interval its status says why)
                status[p] = "at_bound"
        # the effects refitted jointly with it (forward selection, combinations): their intervals the same way
        all_ci = {cand.effect: ci}
        n_free = len(cand.shared) + sum(len(r.shared) for r in task.refit)
        for other in task.refit:
            folds_other = [by_label[f"{task.key}/fold{i}"].values[other.effect] for i in range(k)]
            jack_other = _jackknife([{p: f[p] for p in other.shared} for f in folds_other]) if k > 1 else {}
            all_ci[other.effect] = {}
            for p in other.shared:
                par = REGISTRY[other.effect].parameters[p]
                all_ci[other.effect][p] = interval95(
                    full.values[other.effect][p], full.stderr.get(other.effect, {}).get(p, math.nan),
                    jack_other.get(p, 0.0), n_tests, n_free, full.train_error_mm, self.repeat_scatter_mm_,
                    (par.lower, par.upper), math.nan, other.bounds[p], full.bias_ratio)[0]
        given = dict(cand.start or {}) if task.kind == "refit" else {}
        from .pertest import summarize
        per_test = {p: summarize(v) for p, v in full.per_test.get(cand.effect, {}).items()}
        return CandidateResult(cand.effect, params, stderr, cv, full.train_error_mm, improvement,
                               not implausible, implausible,
                               {f: rms(v) for f, v in sorted(by_load.items())}, fold_params, seconds, nfev,
                               full.values, full.stderr, task.kind, given, ci, status, dict(cand.fixed),
                               per_test, full.per_test, all_ci, {t: e for t, (_, e) in held.items()},
                               full.bias_ratio)

    def _with_start(self, cand: Candidate) -> Candidate:
        """``cand`` starting from the user's ``start`` values (its grid scan, if any, includes them)."""
        given = self.start.get(cand.effect)
        if not given:
            return cand
        params = REGISTRY[cand.effect].parameters
        unknown = sorted(set(given) - set(cand.free))
        if unknown:
            raise ValueError(f"start value for {cand.effect}.{unknown[0]}: not a free parameter of that candidate "
                             f"(free: {', '.join(cand.free) or 'none'})")
        bounds = dict(cand.bounds)
        for k, v in given.items():
            if not params[k].lower <= v <= params[k].upper:
                raise ValueError(f"start value {cand.effect}.{k} = {v} is outside [{params[k].lower}, "
                                 f"{params[k].upper}] {params[k].unit}")
            lo, hi = bounds[k]
            bounds[k] = (min(lo, v), max(hi, v))
        return replace(cand, start={**cand.start_values(), **given}, bounds=bounds)

    def _evidence(self, tests: list[MeasuredTest], base: ModelSpec) -> None:
        """Noise, expected scatter and the evidence in time (:mod:`triplanar.workbench.evidence`)."""
        def evaluate(spec: ModelSpec, ts: Sequence[MeasuredTest]) -> list[TestDiscrepancy]:
            if spec is base and ts is tests:
                return self.baseline_            # the model as given: evaluated already
            return discrepancies(evaluate_spec(spec, ts))
        self.noise_mm_ = instrument_noise_mm(tests)
        self.noise_floor_mm_ = noise_floor_mm(tests, self.noise_mm_)
        self.expected_scatter_mm_ = expected_scatter_mm(base, tests, self.noise_mm_, self.friction_scatter_deg,
                                                        evaluate)
        self.time_domain_ = time_domain(self.baseline_)
        self.systematic_ = systematic_bias(self.baseline_)
        # a bias below the scatter: an entry that removes any of it may explain it (judged by what it leaves); a model
        # whose error is above the scatter keeps the usual bar
        scatter = self.repeat_scatter_mm_
        below = math.isfinite(scatter) and self.baseline_error_mm_ <= self.quiet_factor * scatter
        least = 1e-9 if self.systematic_["systematic"] and below else self.min_improvement
        explaining = [c for c in self.ranked_ if c.plausible and c.improvement >= least]
        self.best_, self.lookalikes_ = parsimonious(explaining) if explaining else (None, [])
        self.after_, self.best_label_ = None, None
        if self.best_ is not None:
            if self.best_.per_test_values:
                from .pertest import evaluate_per_test
                after = evaluate_per_test(self._spec_of(self.best_), self.best_.per_test_values, tests)
            else:
                after = discrepancies(evaluate_spec(self._spec_of(self.best_), tests))
            self.after_ = after
            self.best_label_ = f"{'refitted ' if self.best_.kind == 'refit' else '+ '}{self.best_.effect}"
            self.time_domain_after_ = time_domain(after)
            self.growth_after_ = growth_along_travel(after)
            self.systematic_after_ = systematic_bias(after)
        else:
            self.time_domain_after_, self.growth_after_ = self.time_domain_, growth_along_travel(self.baseline_)
            self.systematic_after_ = self.systematic_

    def _spec_of(self, result: CandidateResult) -> ModelSpec:
        spec = self.user_base_
        if result.kind == "refit":
            spec = replace(spec, effects=without_effect(spec.effects, result.effect))
        for name, values in result.all_values.items():
            if name != result.effect:
                spec = spec_with_values(spec, name, values)
        return spec_with_values(spec, result.effect, result.all_values[result.effect])

    def _residual_kinds(self, unexplained_mm: float) -> list[str]:
        """What kind of residual remains (the evidence of an ``outside_library`` verdict)."""
        kinds = []
        td = self.time_domain_after_
        if td.get("dominant_frequency_hz") is not None:
            kinds.append(f"periodic at {td['dominant_frequency_hz']:.1f} Hz (a spectral peak in "
                         f"{td['periodic_fraction']:.0%} of the tests)")
        if math.isfinite(self.growth_after_) and self.growth_after_ > 2.0:
            kinds.append(f"growing with travel (the lateral error over the last third of the travel is "
                         f"{self.growth_after_:.1f} x that over the first)")
        scatter, expected = self.repeat_scatter_mm_, self.expected_scatter_mm_
        if math.isfinite(scatter) and math.isfinite(expected) and scatter > self.scatter_factor * expected:
            kinds.append(f"random from test to test (the repeats scatter {scatter:.2f} mm, {scatter / expected:.1f} x "
                         f"the {expected:.2f} mm that instrument noise ({self.noise_mm_:.2f} mm) and a "
                         f"{self.friction_scatter_deg:g} deg friction scatter explain)")
        bias = self.systematic_after_
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

    def _decide(self) -> None:
        scatter = self.repeat_scatter_mm_
        expected = self.expected_scatter_mm_
        base = self.baseline_error_mm_
        self.missing_effect_, self.confidence_, self.verdict_ = None, "none", "outside_library"
        scatter_ok = not (math.isfinite(scatter) and math.isfinite(expected) and scatter > self.scatter_factor * expected)
        periodic = self.time_domain_after_.get("dominant_frequency_hz") is not None
        # a candidate with per-test parameters that brings the error down to what noise and the specimen explain
        # explains the repeats' excess scatter itself: it is judged below even when the error is within that scatter
        per_test_explains = (self.best_ is not None and bool(self.best_.per_test) and math.isfinite(expected)
                             and self.best_.fit_error_mm <= self.scatter_factor * expected)
        systematic = self.systematic_after_["systematic"]
        hidden_bias = self.systematic_["systematic"] and self.best_ is not None   # below the scatter, but shared
        if (math.isfinite(scatter) and base <= self.quiet_factor * scatter and not per_test_explains
                and not hidden_bias):
            self.unexplained_mm_ = base
            if scatter_ok and not periodic and not systematic:
                self.verdict_ = "none_missing"
                self.reason_ = (f"the model already matches the data to within the repeats' own scatter (error "
                                f"{base:.2f} mm, scatter {scatter:.2f} mm), and that scatter is what instrument "
                                f"noise and the specimen's variability explain ({expected:.2f} mm): nothing is missing")
            else:
                self.reason_ = (f"the model matches the data as well as the repeats agree with each other (error "
                                f"{base:.2f} mm, scatter {scatter:.2f} mm), but something outside the library acts: "
                                + "; ".join(self._residual_kinds(base)))
            return
        best = self.best_
        if best is None:
            self.unexplained_mm_ = base
            top = self.ranked_[0] if self.ranked_ else None
            detail = (f"; the best, {top.effect}, removes {top.improvement:.0%} of the error"
                      f"{'' if top.plausible else ' with an implausible ' + ', '.join(top.at_bound)}"
                      if top else "")
            self.reason_ = (f"no candidate explains the discrepancy (none removes at least "
                            f"{self.min_improvement:.0%} of it with plausible parameters){detail}; what remains: "
                            + "; ".join(self._residual_kinds(base)))
            return
        self.unexplained_mm_ = best.cv_error_mm
        others = [c for c in self.ranked_ if c is not best]
        runner = others[0] if others else None
        if best is not self.ranked_[0]:
            why_simpler = (f"{best.effect}{' (refit)' if best.kind == 'refit' else ''} ({len(best.params)} free "
                           f"parameter(s)) is named over {self.ranked_[0].effect} ({len(self.ranked_[0].params)}), "
                           f"whose {self.error_word_} {self.ranked_[0].cv_error_mm:.3f} mm is lower by less than the "
                           f"uncertainty of the difference (one-standard-error rule)")
        else:
            why_simpler = ""
        if best.per_test and math.isfinite(expected):
            # per-test parameters explain test-to-test differences: what they leave is judged against what noise
            # and the specimen explain, not against the repeats' scatter (which they are meant to absorb)
            scatter = min(scatter, expected) if math.isfinite(scatter) else expected
            scatter_ok = best.fit_error_mm <= self.scatter_factor * expected
        explained = ((not math.isfinite(scatter)) or best.cv_error_mm <= self.explained_factor * scatter) \
            and not systematic
        diff, diff_se = difference_se(best, runner) if runner is not None else (math.nan, math.nan)
        # the runner-up must be worse by the margin and by more than the uncertainty of the difference, and no
        # entry may be within that uncertainty of the one named (a look-alike)
        separated = runner is None or not math.isfinite(runner.cv_error_mm) or (
            runner.cv_error_mm >= self.margin * best.cv_error_mm and not (math.isfinite(diff) and diff <= diff_se)
            and not self.lookalikes_)
        hinted = not systematic and self.systematic_after_["p_value_all"] < HINT_ALPHA
        held_out = len(self.folds_) > 1     # one load level: nothing was held out, nothing was judged out of sample
        high = (best.improvement >= self.high_improvement and explained and separated and scatter_ok and not periodic
                and not hinted and held_out)
        self.confidence_ = "high" if high else "low"
        what = (f"refitting the given {best.effect} ({_fmt(best.given)} -> {_fmt(best.params)})"
                if best.kind == "refit" else best.effect)
        why = [f"{what} removes {best.improvement:.0%} of the error {self.where_}"]
        if math.isfinite(scatter):
            if best.per_test and math.isfinite(expected):
                why.append(f"leaving {best.cv_error_mm:.2f} mm against the {expected:.2f} mm that noise and the "
                           f"specimen explain (its per-test {', '.join(best.per_test)} absorb the repeats' scatter of "
                           f"{self.repeat_scatter_mm_:.2f} mm)")
            else:
                why.append(f"leaving {best.cv_error_mm:.2f} mm against a repeat scatter of {scatter:.2f} mm")
        if why_simpler:
            why.append(why_simpler)
        if self.lookalikes_:
            why.append("the data cannot tell it from " + ", ".join(
                f"{c.effect}{' (refit)' if c.kind == 'refit' else ''} ({self.error_word_} {c.cv_error_mm:.3f} mm)"
                for c in self.lookalikes_) + ": within the uncertainty of the difference")
        if runner is not None:
            why.append(f"runner-up {runner.effect}{' (refit)' if runner.kind == 'refit' else ''} leaves "
                       f"{runner.cv_error_mm:.2f} mm")
        if self.time_domain_.get("mostly_in_time"):
            why.append(f"the model's error was mostly in time (travel lag {self.time_domain_['lag_rms_mm']:.2f} mm "
                       f"RMS, mean path distance {self.time_domain_['mean_distance_mm']:.2f} mm)")
        if hidden_bias and not systematic and math.isfinite(scatter) and base <= self.quiet_factor * scatter:
            why.append(f"the model as given left a bias common to all tests below the scatter "
                       f"({self.systematic_['feature']}, p = {self.systematic_['p_value_all']:.2g}) that it removes")
        if explained and scatter_ok and not periodic:
            self.verdict_ = "refit_given_effect" if best.kind == "refit" else "library_effect"
            if best.kind == "candidate":
                self.missing_effect_ = best.effect
        else:
            # a library effect helps, but what it leaves is not noise: say so rather than name it as the answer
            self.verdict_ = "outside_library"
            self.missing_effect_ = best.effect if best.kind == "candidate" else None
            why.append("but what remains is not noise: " + "; ".join(self._residual_kinds(best.cv_error_mm)))
        if not high:
            why.append("low confidence: " + "; ".join(self._lacks(best, systematic, explained, separated,
                                                                 scatter_ok and not periodic, hinted)))
        self.reason_ = "; ".join(why)

    def _lacks(self, best: CandidateResult, systematic: bool, explained: bool, separated: bool, clean: bool,
               hinted: bool) -> list[str]:
        """Why the confidence is not ``high``."""
        lacks = []
        if best.improvement < self.high_improvement:
            lacks.append(f"it removes less than {self.high_improvement:.0%}")
        if systematic:
            lacks.append("a bias common to all tests remains")
        elif not explained:
            lacks.append("what remains is well above the repeat scatter (another effect may be missing)")
        if not separated:
            lacks.append("a look-alike explains the data as well" if self.lookalikes_ else
                         "the runner-up explains the data almost as well")
        if not clean:
            lacks.append("the residual shows a pattern no library effect explains")
        if len(self.folds_) < 2:
            lacks.append("with one load level nothing was held out")
        if hinted:
            bias = self.systematic_after_
            lacks.append(f"a hint of a bias common to all tests remains ({bias['feature']}, p = "
                         f"{bias['p_value_all']:.2g}): an unmodelled effect may have shifted the parameters")
        return lacks

    def missing_kind(self) -> str | None:
        """``"physics"``, ``"instrument"`` or ``"physics and instrument"``: what the named entries act on."""
        names = [m["effect"] for m in self.missing_effects_] or ([self.missing_effect_] if self.missing_effect_ else [])
        kinds = sorted({REGISTRY[n].acts_on for n in names if n in REGISTRY})
        return " and ".join(kinds) if kinds else None

    def _single_missing(self) -> list[dict[str, Any]]:
        """``missing_effects`` of a one-entry verdict (the named candidate, or the refit)."""
        best = self.best_
        if best is None or self.verdict_ not in ("library_effect", "refit_given_effect"):
            return []
        return [{"effect": best.effect, "kind": best.kind, "params": dict(best.params),
                 "param_ci95": dict(best.param_ci95), "cv_error_mm": best.cv_error_mm,
                 "share_of_improvement": best.improvement, "confidence": self.confidence_}]

    def _report(self) -> dict[str, Any]:
        def finite(v: float | None) -> float | None:
            return v if v is not None and math.isfinite(v) else None

        return {"verdict": self.verdict_,
                "missing_effect": self.missing_effect_,
                "missing_effects": self.missing_effects_,
                "missing_kind": self.missing_kind(),
                "indistinguishable_from": [f"{c.effect}{' (refit)' if c.kind == 'refit' else ''}"
                                           for c in getattr(self, "lookalikes_", [])] if self.best_ else [],
                "systematic": {"model_as_given": self.systematic_, "after_best": self.systematic_after_},
                "combination": self.combination_,
                "deciding_experiments": self.experiments_,
                "confidence": self.confidence_,
                "reason": self.reason_,
                "baseline_error_mm": self.baseline_error_mm_,
                "candidates": [c.as_json() for c in self.candidates_],
                "refit_results": [c.as_json() for c in self.refits_],
                "refits": [{"effect": r.effect, "param": p, "given": r.given.get(p), "fitted": r.params[p],
                            "ci95": r.param_ci95.get(p), "status": r.param_status.get(p),
                            "cv_error_mm": r.cv_error_mm, "improvement": r.improvement}
                           for r in self.refits_ for p in r.params],
                "noise": {"instrument_noise_mm": finite(self.noise_mm_),
                          "noise_floor_mm": finite(self.noise_floor_mm_),
                          "expected_scatter_mm": finite(self.expected_scatter_mm_),
                          "friction_scatter_deg": self.friction_scatter_deg,
                          "repeat_scatter_mm": finite(self.repeat_scatter_mm_),
                          "unexplained_error_mm": finite(self.unexplained_mm_)},
                "time_domain": {**self.time_domain_, "after_best": self.time_domain_after_},
                "repeat_scatter_mm": finite(self.repeat_scatter_mm_),
                "baseline_error_by_load_mm": {f"{k:g}": v for k, v in self.baseline_by_load_.items()},
                "model": self.base_.describe(),
                "folds_N": [[float(f) for f in fold] for fold in self.folds_],
                "cross_validated": len(self.folds_) > 1,
                "n_tests": len(self.baseline_),
                "seconds": round(self.seconds_, 2)}

    # -- using the result -----------------------------------------------------------------------------
    def best_spec(self) -> ModelSpec:
        """The model with the named missing effect (and any refitted ones) at their fitted values (the
        model itself if none is named)."""
        if self.verdict_ == "library_effects":
            return self.combined_spec_
        if self.verdict_ == "refit_given_effect" and self.best_ is not None:
            return self._spec_of(self.best_)
        if self.missing_effect_ is None:
            return self.base_
        best = next(c for c in self.candidates_ if c.effect == self.missing_effect_)
        return self._spec_of(best)

    def score(self, tests: Sequence[MeasuredTest]) -> float:
        """Fraction of the model's RMS discrepancy on ``tests`` removed by adding the named effect (0 when
        none is named). Higher is better, as in scikit-learn."""
        if self.missing_effect_ is None:
            return 0.0
        base = overall_error(discrepancies(evaluate_spec(self.base_, tests)))
        new = overall_error(discrepancies(evaluate_spec(self.best_spec(), tests)))
        return 1.0 - new / base if base > 0 else 0.0
