"""Which effect is the model missing? Try each candidate, fit it, cross-validate by load level, rank, decide.

For every candidate effect (:mod:`triplanar.workbench.candidates`) and every effect the user gave (freed: a
*refit*), the :class:`Diagnoser` fits its parameters with the effect added to the user's model, once per
cross-validation fold (trained on the other load levels, scored on the fold's levels) and once on all tests (the
reported estimate): :mod:`triplanar.workbench.sweep`, mapped over the executor, so the sweep parallelises across
processes (or a cluster) without change. Entries are ranked by cross-validated RMS discrepancy
(``cv_error_mm``); the evidence (noise, expected scatter, the residual in time, a bias shared by all tests:
:mod:`triplanar.workbench.evidence`) and the rules of :mod:`triplanar.workbench.verdict` decide what is named and
how confidently; when no single entry explains the data, :mod:`triplanar.workbench.combine` tries entries in
combination.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any, Mapping, Sequence

from ..effects import REGISTRY
from ..measurement import MeasuredTest
from . import verdict
from .candidates import Candidate, refit_candidate, resolve, without_effect
from .discrepancy import TestDiscrepancy, repeat_scatter_mm
from .evidence import expected_scatter_mm, growth_along_travel, instrument_noise_mm, noise_floor_mm, systematic_bias, \
    time_domain
from .executor import ExecutorLike, TaskCheckpoint, run_tasks
from .fit import discrepancies, errors_by_load, evaluate_spec, overall_error
from .parsimony import parsimonious
from .spec import ModelSpec, spec_with_values
from .sweep import CandidateResult, CandidateTask, assemble, load_folds, profile_result, run_candidate

__all__ = ["CandidateResult", "CandidateTask", "Diagnoser", "load_folds", "run_candidate"]


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
        combine: when no single entry explains the data, try entries in combination (:mod:`.combine`).
        model_form: give the named entry profile-likelihood intervals (:mod:`.profile`) and the model-form allowance
            (:mod:`.alternatives`: refits with each further one-parameter physical effect).

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
                 per_test: Mapping[str, Sequence[str]] | None = None, combine: bool = True,
                 model_form: bool = True):
        self.combine = combine
        self.model_form = model_form
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
        results = [assemble(t, by_label, len(folds), len(tests), self.baseline_error_mm_,
                            self.repeat_scatter_mm_) for t in tasks]
        results.sort(key=lambda r: (not math.isfinite(r.cv_error_mm), r.cv_error_mm))
        self.candidates_ = [r for r in results if r.kind == "candidate"]
        self.refits_ = [r for r in results if r.kind == "refit"]
        self.ranked_ = results
        self.outcomes_ = by_label
        self._evidence(tests, base)
        if self.best_ is not None and self.model_form:
            # the named entry: profile-likelihood intervals beside the curvature ones, and the model-form allowance
            task = next(t for t in tasks if t.key == f"{self.best_.kind}:{self.best_.effect}")
            profile_result(task, self.best_, tests, self.repeat_scatter_mm_)
            from .alternatives import apply_alternatives
            apply_alternatives(self, self.best_, task, tests)
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
        recipe = {p.name: p for p in cand.recipe}
        edits = []
        for k, v in given.items():
            if not params[k].lower <= v <= params[k].upper:
                raise ValueError(f"start value {cand.effect}.{k} = {v} is outside [{params[k].lower}, "
                                 f"{params[k].upper}] {params[k].unit}")
            p = recipe[k]
            edits.append(replace(p, value=float(v), start=float(v), min=min(p.min, v), max=max(p.max, v)))
        return cand.with_parameters(edits)

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


    # -- the verdict (triplanar.workbench.verdict) ------------------------------------------------------
    def _decide(self) -> None:
        verdict.decide(self)

    def _residual_kinds(self, unexplained_mm: float) -> list[str]:
        return verdict.residual_kinds(self, unexplained_mm)

    def missing_kind(self) -> str | None:
        """``"physics"``, ``"instrument"`` or ``"physics and instrument"``: what the named entries act on."""
        return verdict.missing_kind(self)

    def _single_missing(self) -> list[dict[str, Any]]:
        return verdict.single_missing(self)

    def _report(self) -> dict[str, Any]:
        return verdict.report(self)

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
