"""Which effect is the model missing? Try each candidate, fit it, cross-validate by load level, rank, decide.

For every candidate effect (:mod:`triplanar.workbench.candidates`) and every effect the user gave (freed: a
*refit*), the :class:`Diagnoser` fits its parameters with the effect added to the user's model, once per
cross-validation fold (trained on the other load levels, scored on the fold's levels) and once on all tests (the
reported estimate): :mod:`triplanar.workbench.sweep`, mapped over the executor, so the sweep parallelises across
processes (or a cluster) without change. Entries are ranked by cross-validated RMS discrepancy
(``cv_error_mm``). ``fit`` gathers the evidence into one value (:class:`~triplanar.workbench.verdict.Evidence`: the
fits and their intervals, noise, expected scatter, the residual in time, a bias shared by all tests
(:mod:`triplanar.workbench.evidence`), the model-form alternatives (:mod:`triplanar.workbench.alternatives`), the
deciding experiments (:mod:`triplanar.workbench.experiment`) and, when the best single entry leaves a pattern, entries
in combination (:mod:`triplanar.workbench.combine`)); :func:`triplanar.workbench.rules.decide` alone turns it into
the :class:`~triplanar.workbench.verdict.Verdict`.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any, Mapping, Sequence

from ..effects import REGISTRY
from ..measurement import MeasuredTest
from . import rules
from .candidates import Candidate, refit_candidate, resolve, without_effect
from .discrepancy import TestDiscrepancy, repeat_scatter_mm
from .evidence import expected_scatter_mm, growth_along_travel, instrument_noise_mm, noise_floor_mm, systematic_bias, \
    time_domain
from .executor import ExecutorLike, TaskCheckpoint, run_tasks
from .fit import discrepancies, errors_by_load, evaluate_spec, overall_error
from .given import audit_given       # (imported here also so that kept Evidence holding a GivenAudit reads back)
from .locate import locate           # (imported here also so that kept Evidence holding a LocatedResult reads back)
from .rigidity import RigidityResult, rigidity
from .spec import ModelSpec, spec_with_values
from .sweep import CandidateResult, CandidateTask, assemble, load_folds, profile_result, residual_of, run_candidate, \
    spec_of
from .verdict import Evidence, VerdictKind, missing_kind, report_json, shown_after

__all__ = ["CandidateResult", "CandidateTask", "Diagnoser", "load_folds", "run_candidate"]


def _evidence_field(name: str, doc: str) -> property:
    return property(lambda self: getattr(self.evidence_, name), doc=doc)


def _verdict_field(name: str, doc: str) -> property:
    return property(lambda self: getattr(self.decision_, name), doc=doc)


class Diagnoser:
    """Find the effect a model lacks (scikit-learn style: configure, ``fit(tests)``, read attributes).

    Args:
        candidates: effect names or :class:`Candidate` recipes (default: every registered effect that is screened,
            ``Effect.screened``, minus those already in the model).
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

        friction_scatter_deg: the specimen's repeat-to-repeat friction scatter ``expected_scatter_mm`` assumes (deg).
        audit: audit the given numbers (the specimen's and the instruments') beside the effects
            (:func:`~triplanar.workbench.given.audit_given`).
        locate: when the verdict is ``outside_library`` or ``high`` (naming more than one parameter), locate a cause
            outside the library as one extra force on the block (:func:`~triplanar.workbench.locate.locate`: its
            point, direction and what it follows; for an outside verdict evidence for the user, for a high one the
            rival that :func:`~triplanar.workbench.rules.decide` holds it against). ``False``: the confidence as
            without that rule.

    Fitted attributes (set by ``fit`` only): ``evidence_`` (:class:`~triplanar.workbench.verdict.Evidence`: what
    was gathered), ``decision_`` (:class:`~triplanar.workbench.verdict.Verdict`: what
    :func:`~triplanar.workbench.rules.decide` made of it), ``seconds_``; views of them: ``report_`` (the JSON
    report), ``verdict_`` (its kind's name), ``missing_effect_``, ``missing_effects_``, ``confidence_``,
    ``reason_``, ``candidates_`` (list of :class:`CandidateResult`, best first), ``refits_``, ``ranked_``,
    ``best_``, ``lookalikes_``, ``baseline_`` (per-test discrepancies), ``baseline_error_mm_``,
    ``repeat_scatter_mm_``, ...
    """

    def __init__(self, candidates: Sequence[str | Candidate] | None = None, folds: int = 3,
                 executor: ExecutorLike = None, progress: bool = True, max_nfev: int = 30,
                 checkpoint: TaskCheckpoint | None = None, refit_given: bool = True,
                 start: Mapping[str, Mapping[str, float]] | None = None,
                 per_test: Mapping[str, Sequence[str]] | None = None, combine: bool = True,
                 model_form: bool = True, friction_scatter_deg: float = rules.FRICTION_SCATTER_DEG,
                 audit: bool = True, locate: bool = True):
        self.audit = audit
        self.locate = locate
        self.friction_scatter_deg = friction_scatter_deg
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
        """Diagnose ``tests`` against ``base`` (default: case B, reference specimen): gather the evidence, and let
        :func:`~triplanar.workbench.rules.decide` make the verdict of it (``evidence_``, ``decision_``).

        ``refit``: effects already added to the model, ``{name: {param: value}}``; they are part of the
        model being diagnosed, and their parameters are re-estimated jointly with each candidate's (what
        forward selection does)."""
        began = time.perf_counter()
        base = base or ModelSpec()
        tests = list(tests)
        if not tests:
            raise ValueError("diagnose needs at least one measured test")
        refit = {k: dict(v) for k, v in (refit or {}).items()}
        user_base = base
        tasks = self._tasks(tests, user_base, refit)
        for name, values in refit.items():
            base = spec_with_values(base, name, values)
        baseline = discrepancies(evaluate_spec(base, tests))
        baseline_error = overall_error(baseline)
        scatter = repeat_scatter_mm(tests, base.rest_positions)
        folds = load_folds([t.shear_force_N for t in tests], self.folds)
        tasks = [replace(t, folds=tuple(tuple(f) for f in folds)) for t in tasks]
        # Slowest first (slow simulations, many parameters), so that the pool stays balanced.
        tasks.sort(key=lambda t: (t.candidate.effect != "actuator_rise", -len(t.candidate.free)))
        outcomes = run_tasks(run_candidate, tasks, self.executor, self.progress, desc="diagnose",
                             checkpoint=self.checkpoint)
        by_label = {f"{t.key}/{k}": v for t, out in zip(tasks, outcomes) for k, v in out.items()}
        ranked = [assemble(t, by_label, len(folds), len(tests), baseline_error, scatter) for t in tasks]
        ranked.sort(key=lambda r: (not math.isfinite(r.cv_error_mm), r.cv_error_mm))
        # instrument or specimen, from the rigid block (read by the rules: which entry is examined, no high for
        # physics on an instrument fault, where forward selection starts, a contact point off the drawing)
        rigid = rigidity(tests, user_base.rest_positions)
        ev = replace(self._gather(tests, user_base, base, refit, folds, baseline, scatter, ranked, rigid),
                     rigidity=rigid)
        if self.audit:      # the given numbers (specimen, instruments) beside the effects: screened, likely ones fitted
            ev = replace(ev, given_numbers=audit_given(ev, tasks, tests, self.executor, self.progress))
        if ev.best is not None and self.model_form:
            # the examined entry: profile-likelihood intervals beside the curvature ones, and the model-form allowance
            task = next(t for t in tasks if t.key == f"{ev.best.kind}:{ev.best.effect}")
            self._model_form(ev, task, tests)
        from .experiment import experiments_for
        ev = replace(ev, experiments=tuple(experiments_for(ev, tests)))
        if self.combine and rules.tries_combination(ev):
            from .combine import combine
            ev = replace(ev, combination=combine(self, ev, tests))
        self.decision_ = rules.decide(ev)
        if self.locate and rules.locates(ev, self.decision_):
            # where an extra force would act, and what it follows: evidence for the user of an outside verdict, and
            # for a high one naming more than one parameter the rival that keeps it high only when the force does not
            # predict as well
            ev = replace(ev, located=locate(tests, ev.base, ev.folds, self.executor))
            self.decision_ = rules.decide(ev)
        self.evidence_ = ev
        self.seconds_ = time.perf_counter() - began
        return self

    def _tasks(self, tests: list[MeasuredTest], user_base: ModelSpec,
               refit: dict[str, dict[str, float]]) -> list[CandidateTask]:
        """One task per candidate and per given effect freed (its folds filled in by ``fit``)."""
        refit_cands = tuple(resolve(list(refit), specimen=user_base.specimen))
        cands = resolve(self.candidates, exclude=(*user_base.effect_names, *refit), specimen=user_base.specimen)
        # the user's given effects, each freed in turn (the others and any forward-selection refits kept)
        given = [(name, dict(values)) for name, values in user_base.effects if REGISTRY[name].parameters
                 and any(p.free for p in REGISTRY[name].parameters.values())] if self.refit_given else []
        cands = [self._with_start(c.with_per_test(self.per_test[c.effect]) if c.effect in self.per_test else c)
                 for c in cands]
        unknown = sorted(set(self.per_test) - {c.effect for c in cands})
        if unknown:
            raise ValueError(f"per-test parameters of {unknown[0]!r}: that effect is not a candidate")
        if not cands and not given:
            raise ValueError("no candidate effects to try (all are already in the model)")
        tasks = [CandidateTask(user_base, c, tuple(tests), (), self.max_nfev, refit_cands, refit) for c in cands]
        for name, values in given:
            stripped = replace(user_base, effects=without_effect(user_base.effects, name))
            tasks.append(CandidateTask(stripped, refit_candidate(name, values, user_base.specimen), tuple(tests), (),
                                       self.max_nfev, refit_cands, refit, kind="refit"))
        return tasks

    def _model_form(self, ev: Evidence, task: CandidateTask, tests: list[MeasuredTest]) -> None:
        """Record the examined entry's profile-likelihood intervals and model-form allowance on it."""
        from .alternatives import model_form_of, model_interval
        best = ev.best
        assert best is not None
        profile_result(task, best, tests, ev.repeat_scatter_mm)
        found = model_form_of(best, task, tests, ev.user_base, list(ev.refit), self.executor)
        if found is not None:
            best.model_form = found
            best.set_intervals("model_form", model_interval(best))

    def next_round(self) -> Diagnoser:
        """A diagnoser for a further round of forward selection (:mod:`~triplanar.workbench.combine`): the same
        candidates, folds, executor and start values; no progress bar, no refits of given effects, no combination,
        no model-form step."""
        return Diagnoser(self.candidates, self.folds, self.executor, False, self.max_nfev, refit_given=False,
                         start=self.start, combine=False, model_form=False,
                         friction_scatter_deg=self.friction_scatter_deg, audit=False, locate=False)

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

    def _gather(self, tests: list[MeasuredTest], user_base: ModelSpec, base: ModelSpec,
                refit: dict[str, dict[str, float]], folds: list[list[float]], baseline: list[TestDiscrepancy],
                scatter: float, ranked: list[CandidateResult], rigid: RigidityResult) -> Evidence:
        """Noise, expected scatter, the evidence in time and the examined entry's residual
        (:mod:`triplanar.workbench.evidence`)."""
        def evaluate(spec: ModelSpec, ts: Sequence[MeasuredTest]) -> list[TestDiscrepancy]:
            if spec is base and ts is tests:
                return baseline            # the model as given: evaluated already
            return discrepancies(evaluate_spec(spec, ts))
        noise = instrument_noise_mm(tests)
        baseline_error = overall_error(baseline)
        systematic = systematic_bias(baseline)
        best, lookalikes = rules.examined_entry(ranked, baseline_error, scatter, systematic["p_value_all"], rigid)
        after = residual_of(user_base, best, tests) if best is not None else None
        shown = after if after is not None else baseline
        return Evidence(user_base, base, refit, folds, baseline, baseline_error, errors_by_load(baseline), scatter,
                        noise, noise_floor_mm(tests, noise),
                        expected_scatter_mm(base, tests, noise, self.friction_scatter_deg, evaluate),
                        self.friction_scatter_deg, ranked, time_domain(baseline), systematic, best, lookalikes, after,
                        time_domain(shown), growth_along_travel(shown), systematic_bias(shown) if after is not None
                        else systematic, implementation_tolerance_mm=rules.IMPLEMENTATION_TOLERANCE_M * 1e3)

    # -- views of the evidence and the verdict (read-only) ---------------------------------------------------------
    verdict_ = property(lambda self: self.decision_.kind.value, doc="The verdict's kind (``\"library_effect\"``, ...).")
    missing_effect_ = _verdict_field("missing_effect", "The library effect named (``None`` for a refit or nothing).")
    confidence_ = _verdict_field("confidence", "``high``, ``low`` or ``none``.")
    reason_ = _verdict_field("reason", "The verdict's reason in one sentence.")
    unexplained_mm_ = _verdict_field("unexplained_mm", "What the verdict leaves unexplained (mm).")
    missing_effects_ = property(lambda self: [e.as_json() for e in self.decision_.effects],
                                doc="The named entries as the report lists them.")
    combination_ = _verdict_field("combination", "The combination tried, as judged (``None`` if none was).")
    experiments_ = _evidence_field("experiments", "The deciding experiments between look-alikes.")
    user_base_ = _evidence_field("user_base", "The model as given.")
    base_ = _evidence_field("base", "The model diagnosed (with any forward-selection effects at their values).")
    refit_ = _evidence_field("refit", "The forward-selection effects refitted with every candidate.")
    baseline_ = _evidence_field("baseline", "Per-test discrepancies of the model as given.")
    baseline_error_mm_ = _evidence_field("baseline_error_mm", "RMS discrepancy of the model as given (mm).")
    baseline_by_load_ = _evidence_field("baseline_by_load", "Its RMS discrepancy per load (mm).")
    repeat_scatter_mm_ = _evidence_field("repeat_scatter_mm", "The repeats' scatter (mm).")
    expected_scatter_mm_ = _evidence_field("expected_scatter_mm", "What noise and the specimen explain (mm).")
    folds_ = _evidence_field("folds", "The cross-validation folds (load levels).")
    ranked_ = _evidence_field("ranked", "Every entry, best cross-validated error first.")
    candidates_ = _evidence_field("candidates", "The candidates, best first.")
    refits_ = _evidence_field("refits", "The given effects refitted, best first.")
    best_ = _evidence_field("best", "The entry examined (``None`` when none explains).")
    lookalikes_ = _evidence_field("lookalikes", "Entries the data cannot tell from it.")

    @property
    def report_(self) -> dict[str, Any]:
        """The JSON report (``diagnose.json``): a view of ``decision_`` and ``evidence_``."""
        return report_json(self.evidence_, self.decision_, self.seconds_)

    @property
    def after_(self) -> list[TestDiscrepancy] | None:
        """Per-test discrepancies of the named model (the combination's when it is named)."""
        return shown_after(self.evidence_, self.decision_)[0]

    @property
    def best_label_(self) -> str | None:
        return shown_after(self.evidence_, self.decision_)[3]

    def missing_kind(self) -> str | None:
        """``"physics"``, ``"instrument"`` or ``"instrument and physics"``: what the named entries act on."""
        return missing_kind(self.decision_)

    # -- using the result -----------------------------------------------------------------------------
    def best_spec(self) -> ModelSpec:
        """The model with the named missing effect (and any refitted ones) at their fitted values (the
        model itself if none is named)."""
        ev, verdict = self.evidence_, self.decision_
        if verdict.kind is VerdictKind.LIBRARY_EFFECTS and ev.combination is not None and ev.combination.spec:
            return ev.combination.spec
        if verdict.kind is VerdictKind.REFIT_GIVEN_EFFECT and ev.best is not None:
            return spec_of(ev.user_base, ev.best)
        if verdict.missing_effect is None:
            return ev.base
        best = next(c for c in ev.candidates if c.effect == verdict.missing_effect)
        return spec_of(ev.user_base, best)

    def score(self, tests: Sequence[MeasuredTest]) -> float:
        """Fraction of the model's RMS discrepancy on ``tests`` removed by adding the named effect (0 when
        none is named). Higher is better, as in scikit-learn."""
        if self.missing_effect_ is None:
            return 0.0
        base = overall_error(discrepancies(evaluate_spec(self.base_, tests)))
        new = overall_error(discrepancies(evaluate_spec(self.best_spec(), tests)))
        return 1.0 - new / base if base > 0 else 0.0
