"""Fitting effects' parameters to measured tests: bounded least squares on the RMS discrepancy.

The objective is the sum over tests of ``error_mm ** 2`` (:mod:`triplanar.workbench.discrepancy`): every
test weighs the same. Parameters are scaled to [0, 1] over their fit range and fitted with
``scipy.optimize.least_squares`` (trust-region reflective, finite-difference Jacobian); a one-parameter
fit first scans a coarse grid so that it does not polish a local minimum near its start.

Uncertainty (``stderr``): the cluster-robust sandwich ``(J'J)^-1 (sum_t J_t' r_t r_t' J_t) (J'J)^-1`` with
one cluster per test (samples of one trace are strongly correlated; tests are the independent units),
with each test's residuals as they would be had the fit not seen it (CR3, the delete-one-test jackknife in closed
form: :func:`~triplanar.workbench.fitbase.cluster_robust_stderr`).

:func:`run_fit` is the pure unit of work of a sweep (a :class:`FitTask` in, a :class:`FitOutcome` out);
:class:`EffectFit` is the estimator a user calls (``fit``, ``score``, ``predict``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ..effects import REGISTRY, Effect, EffectError
from ..measurement import MeasuredTest
from ..result import SimulationResult
from .candidates import Candidate, refit_candidate, resolve
from .discrepancy import TestDiscrepancy, repeat_scatter_mm, rms
from .intervals import interval95
from .parameters import (FitParameter, at_bound_of, intervals_of, profiles_of, shared_values, standard_errors,
                         statuses_of)
from .executor import ExecutorLike, executor_scope
from .fitbase import DIFF_STEP, FitOutcome, ScaledBox, cluster_robust_stderr, safe_evaluate
from .spec import EvalResult, EvalTask, ModelSpec, group_by_force, spec_with_values, tasks_for



# -- evaluating a model on tests --------------------------------------------------------------------

def evaluate_spec(spec: ModelSpec, tests: Sequence[MeasuredTest], mapper: Callable = map,
                  keep_result: bool = False) -> list[EvalResult]:
    """Evaluate ``spec`` on ``tests`` (one simulation per force), through ``mapper`` (``map`` or an
    executor's ``map``)."""
    return list(mapper(safe_evaluate, tasks_for(spec, tests, keep_result)))


def discrepancies(results: Iterable[EvalResult]) -> list[TestDiscrepancy]:
    """Flatten evaluation results into per-test discrepancies."""
    return [d for r in results for d in r.discrepancies]


def overall_error(found: Iterable[TestDiscrepancy]) -> float:
    """The dataset's RMS discrepancy: root mean square of the tests' ``error_mm``."""
    return rms([d.error_mm for d in found])


def errors_by_load(found: Iterable[TestDiscrepancy]) -> dict[float, float]:
    """RMS discrepancy per load level."""
    groups: dict[float, list[float]] = {}
    for d in found:
        groups.setdefault(d.force_N, []).append(d.error_mm)
    return {f: rms(v) for f, v in sorted(groups.items())}


# -- the fitting problem -----------------------------------------------------------------------------

@dataclass(frozen=True)
class FitTask:
    """Fit ``candidates`` (jointly) added to ``base`` on ``train``; then score ``held_out``."""

    base: ModelSpec
    candidates: tuple[Candidate, ...]
    train: tuple[MeasuredTest, ...]
    held_out: tuple[MeasuredTest, ...] = ()
    start: tuple[float, ...] | None = None
    max_nfev: int = 30
    label: str = ""
    warm: Mapping[str, Mapping[str, float]] | None = None
    phi_start: Mapping[str, tuple[float, ...]] | None = None   # per-test parameters: each test's start


class Problem(ScaledBox):
    """Scaling, packing and the residual function of a joint fit of several candidates.

    Evaluations are cached per (parameter vector, load level) in ``cache``, which several problems over
    the same tests may share (the cross-validation folds of one candidate share their grid scan and first
    Jacobian this way: folds split by load level, so a level's tests are the same in every problem).
    """

    def __init__(self, base: ModelSpec, candidates: Sequence[Candidate], tests: Sequence[MeasuredTest],
                 mapper: Callable = map, cache: dict | None = None):
        self.base, self.candidates, self.tests, self.mapper = base, list(candidates), list(tests), mapper
        self.names = [(c.effect, p) for c in self.candidates for p in c.free]
        self.lo = np.array([c.bounds[p][0] for c in self.candidates for p in c.free], dtype=float)
        self.hi = np.array([c.bounds[p][1] for c in self.candidates for p in c.free], dtype=float)
        self.cache: dict[tuple, tuple[TestDiscrepancy, ...]] = {} if cache is None else cache
        self.nfev = 0

    def start(self, warm: Mapping[str, Mapping[str, float]] | None = None) -> np.ndarray:
        """Scaled start: ``warm[effect][param]`` where given, else each candidate's neutral start."""
        warm = warm or {}
        return self.scaled([float(warm.get(c.effect, {}).get(p, c.start_values()[p]))
                            for c in self.candidates for p in c.free])

    def values(self, x: np.ndarray) -> dict[str, dict[str, float]]:
        out: dict[str, dict[str, float]] = {}
        i = 0
        for c in self.candidates:
            free = {p: float(x[i + k]) for k, p in enumerate(c.free)}
            out[c.effect] = c.values(free)
            i += len(c.free)
        return out

    def spec(self, x: np.ndarray) -> ModelSpec:
        spec = self.base
        for name, values in self.values(x).items():
            spec = spec_with_values(spec, name, values)
        return spec

    def evaluate(self, u: np.ndarray,
                 tests: Sequence[MeasuredTest] | None = None) -> tuple[np.ndarray, list[TestDiscrepancy]]:
        """Residuals and per-test discrepancies at scaled parameters ``u`` on ``tests`` (default: the
        problem's own)."""
        u = np.asarray(u, dtype=float)
        groups = group_by_force(self.tests if tests is None else tests)
        key = tuple(np.round(u, 12))
        missing = [f for f in groups if (key, f, len(groups[f])) not in self.cache]
        if missing:
            spec = self.spec(self.natural(u))
            tasks = [EvalTask(spec, f, groups[f], report=False) for f in missing]
            for f, result in zip(missing, self.mapper(safe_evaluate, tasks)):
                self.cache[(key, f, len(groups[f]))] = result.discrepancies
        found = [d for f in groups for d in self.cache[(key, f, len(groups[f]))]]
        if tests is None:
            self.nfev += 1
        residuals = np.concatenate([d.residuals for d in found]) if found else np.zeros(0)
        return residuals, found

    def residuals(self, u: np.ndarray) -> np.ndarray:
        return self.evaluate(u)[0]


def grid_start(problem: Problem, candidate: Candidate, u0: np.ndarray | None = None) -> np.ndarray:
    """Scan the first candidate's coarse grid over its single parameter (the others held at ``u0``, default
    the neutral start); return the best point (scaled), the start value included.

    With other parameters fitted jointly (refits, forward selection's earlier entries), each grid point also tries
    them moved by one Gauss-Newton step (:func:`_others_step`): their start values were fitted *without* the new
    parameter and may sit far from its valley (end friction fitted alone absorbs a drag; with the drag held at any
    grid value but zero, the old friction angle is worse than none, and the scan would return zero)."""
    u0 = problem.start() if u0 is None else np.asarray(u0, dtype=float)
    values = candidate.grid_values() + [candidate.start_values()[candidate.free[0]]]
    scaled = np.clip((np.array(values) - problem.lo[0]) / (problem.hi[0] - problem.lo[0]), 0.0, 1.0)
    grid = sorted({float(v) for v in scaled.round(12)})
    points = [np.concatenate([[g], u0[1:]]) for g in grid]
    if problem.n > 1:
        points += [_others_step(problem, u) for u in points]
    costs = [float(np.sum(problem.residuals(u) ** 2)) for u in points]
    return points[int(np.argmin(costs))]


def _others_step(problem: Problem, u: np.ndarray) -> np.ndarray:
    """``u`` with every parameter but the first moved by one Gauss-Newton step (forward differences, clipped to the
    box): where the others would go with the first held."""
    r0 = problem.residuals(u)
    cols = []
    for i in range(1, problem.n):
        h = DIFF_STEP if u[i] + DIFF_STEP <= 1.0 else -DIFF_STEP
        w = u.copy()
        w[i] += h
        cols.append((problem.residuals(w) - r0) / h)
    step = np.linalg.lstsq(np.stack(cols, axis=1), -r0, rcond=None)[0]
    out = u.copy()
    out[1:] = np.clip(u[1:] + step, 0.0, 1.0)
    return out


def sandwich_stderr(problem: Problem, u: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """Cluster-robust (one cluster per test, CR3: :func:`~triplanar.workbench.fitbase.cluster_robust_stderr`)
    standard errors in natural units."""
    r, found = problem.evaluate(u)
    jn = jac / (problem.hi - problem.lo)[None, :]                         # d r / d x (natural units)
    blocks, res, start = [], [], 0
    for d in found:
        stop = start + len(d.residuals)
        blocks.append(jn[start:stop])
        res.append(r[start:stop])
        start = stop
    if not blocks:
        return np.full(problem.n, math.inf)
    return cluster_robust_stderr(blocks, res)


def solve(problem: Problem, start: np.ndarray | None = None, max_nfev: int = 30,
          warm: Mapping[str, Mapping[str, float]] | None = None, jac: Callable | None = None):
    """Bounded least squares from ``start`` (natural units); else from the warm/neutral start, with the
    first candidate's parameter taken from the best point of its grid scan when it has one. ``jac``: a given
    Jacobian (d residuals / d scaled parameters) instead of forward differences. Returns (u, jac, message)."""
    if start is not None:
        u0 = problem.scaled(start)
    else:
        u0 = problem.start(warm)
        if problem.candidates[0].grid_values():
            u0 = grid_start(problem, problem.candidates[0], u0)
    res = least_squares(problem.residuals, u0, jac=jac if jac is not None else "2-point", bounds=(0.0, 1.0),
                        method="trf", diff_step=DIFF_STEP, x_scale=1.0, max_nfev=max_nfev, ftol=1e-4, xtol=1e-3,
                        gtol=1e-8)
    return res.x, res.jac, res.message


def jacobian_rows(problem: Problem, u: np.ndarray, jac: np.ndarray) -> dict[str, np.ndarray]:
    """``jac`` (over the problem's residual vector) split into each test's rows, by test id."""
    _, found = problem.evaluate(u, problem.tests)   # (cached: not counted as an evaluation of the fit)
    out, start = {}, 0
    for d in found:
        out[d.test_id] = jac[start:start + len(d.residuals)]
        start += len(d.residuals)
    return out


class BroydenJacobian:
    """The Jacobian of ``problem`` (d residuals / d scaled parameters) started from another fit's rows per test
    and updated along every step the solver takes (Broyden's rank-one secant update; for one parameter the
    secant slope of every residual): no forward differences after the start. Used for the cross-validation
    folds, which start at the full fit's optimum, where the full fit's last Jacobian is already close."""

    def __init__(self, problem: Problem, rows: Mapping[str, np.ndarray]):
        order = [t.test_id for ts in group_by_force(problem.tests).values() for t in ts]
        self.problem = problem
        self.jac = np.concatenate([rows[k] for k in order], axis=0).copy()
        self.last: np.ndarray | None = None

    def __call__(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if self.last is not None:
            du = u - self.last
            dd = float(du @ du)
            if dd > 0:
                r1 = self.problem.evaluate(u, self.problem.tests)[0]       # both cached: the solver evaluated them
                r0 = self.problem.evaluate(self.last, self.problem.tests)[0]
                self.jac += np.outer(r1 - r0 - self.jac @ du, du) / dd
        self.last = u.copy()
        return self.jac.copy()


def run_fit(task: FitTask, mapper: Callable = map, cache: dict | None = None,
            chord: Mapping[str, np.ndarray] | None = None, rows_out: dict | None = None) -> FitOutcome:
    """Fit the task's candidates on its training tests and score its held-out tests (pure; picklable).
    ``cache``: evaluations shared with other fits over the same tests (see :class:`Problem`). ``chord``: the
    Jacobian rows of each training test from another fit (``rows_out`` of the fit on all tests), the start of
    a Broyden-updated Jacobian instead of forward differences (:class:`BroydenJacobian`; the cross-validation
    folds, which start at that fit's optimum); ``rows_out``: filled with this fit's final Jacobian rows by test
    id. Candidates with per-test parameters are fitted by profiling
    (:func:`triplanar.workbench.pertest.run_profiled_fit`)."""
    from .pertest import has_per_test, run_profiled_fit
    if has_per_test(task.candidates):
        return run_profiled_fit(task, mapper)
    began = time.perf_counter()
    problem = Problem(task.base, task.candidates, task.train, mapper, cache)
    u, jac, message = solve(problem, task.start, task.max_nfev, task.warm,
                            BroydenJacobian(problem, chord) if chord is not None else None)
    if rows_out is not None:
        rows_out.update(jacobian_rows(problem, u, jac))
    neutral = problem.start()
    u = np.where(np.abs(u - neutral) < 1e-6, neutral, u)  # the solver's strictly-feasible nudge off a bound
    x = problem.natural(u)
    stderr = sandwich_stderr(problem, u, jac)
    _, found = problem.evaluate(u)
    held: dict[str, tuple[float, float]] = {}
    if task.held_out:
        _, out = problem.evaluate(u, task.held_out)
        held = {d.test_id: (d.force_N, d.error_mm) for d in out}
    values = problem.values(x)
    errs: dict[str, dict[str, float]] = {}
    for (effect, param), se in zip(problem.names, stderr):
        errs.setdefault(effect, {})[param] = float(se)
    at_bound = problem.at_bound(u, neutral)
    return FitOutcome(task.label, tuple(c.effect for c in task.candidates), values, errs, at_bound,
                      overall_error(found), {d.test_id: (d.force_N, d.error_mm) for d in found}, held,
                      problem.nfev, time.perf_counter() - began, str(message), tuple(float(v) for v in x))


def fitted_parameters(cand: Candidate, outcome: FitOutcome, starts: Mapping[str, float], n_tests: int,
                      scatter_mm: float, bias_ratio: float) -> dict[str, FitParameter]:
    """One :class:`FitParameter` per parameter of ``cand`` with the joint fit's result: held ones first, then
    the free ones in the recipe's order; intervals as :func:`~triplanar.workbench.intervals.interval95` (no
    folds, so no jackknife part)."""
    recipe = cand.parameters()
    values, errs = outcome.values.get(cand.effect, {}), outcome.stderr.get(cand.effect, {})
    out = {k: recipe[k] for k in cand.fixed}
    for k in cand.free:
        p = recipe[k]
        at_bound = f"{cand.effect}.{k}" in outcome.at_bound
        if p.per_test:
            out[k] = replace(p, stderr=errs.get(k), status="per_test", at_bound=at_bound,
                             per_test_values=dict(outcome.per_test.get(cand.effect, {}).get(k, {})))
            continue
        ci, status = interval95(values[k], errs[k], 0.0, n_tests, len(cand.shared), outcome.train_error_mm,
                                scatter_mm, (p.spec.lower, p.spec.upper), float(starts[k]), p.bounds, bias_ratio)
        out[k] = replace(p, value=values[k], start=float(starts[k]), stderr=errs[k],
                         ci95=tuple(ci) if ci is not None else None, status="at_bound" if at_bound else status,
                         at_bound=at_bound)
    return out


# -- the estimator -----------------------------------------------------------------------------------

class EffectFit:
    """Add effects to a model and fit their parameters (scikit-learn style).

    >>> fit = EffectFit(["end_friction"]).fit(tests, model)   # doctest: +SKIP
    >>> fit.params_, fit.stderr_, fit.error_mm_, fit.score(other_tests)

    Args:
        add: effect names or :class:`~triplanar.workbench.candidates.Candidate` recipes, fitted jointly.
        start: optional ``{effect: {param: value}}`` start values (warm start).
        executor: runs the per-force simulations of each evaluation (``None``: 2-process pool).
        max_nfev: least-squares evaluations allowed.
        per_test: ``{effect: [param, ...]}``: parameters fitted for each test (the others shared by all tests), in
            addition to those the effect declares ``Parameter(per_test=True)``; fitted by profiling
            (:mod:`~triplanar.workbench.pertest`).

    Fitted attributes: ``parameters_`` (``{effect: {param: FitParameter}}``: value, vary, range, start, per-test,
    standard error, interval and status of each parameter on one object, :mod:`~triplanar.workbench.parameters`)
    and its views ``params_``, ``stderr_``, ``at_bound_``, ``ci95_``, ``status_``; ``spec_`` (base plus the fitted effects),
    ``effects_`` (Effect objects), ``baseline_error_mm_``, ``error_mm_``, ``baseline_by_load_``,
    ``error_by_load_``, ``discrepancies_`` (per test, fitted model), ``outcome_``, ``ci95_`` (``{effect:
    {param: [low, high] or None}}``, :mod:`~triplanar.workbench.intervals`; the jackknife part is absent here, there
    are no folds), ``profile_ci95_`` (the same, from the profile of the objective: :mod:`~triplanar.workbench.profile`;
    empty with per-test parameters; ``intervals_`` then lacks ``"profile"``), ``status_`` (``fitted``, ``fixed``, ``not_moved``, ``degenerate``, ``at_bound``), ``refitted_``
    (effects of the model that were freed: ``{name: values the user gave}``), ``per_test_`` (``{effect: {param:
    {test_id: value}}}``, empty without per-test parameters; ``params_`` then holds the shared values, and the
    per-test parameters have the status ``per_test`` and no interval), ``per_test_summary_`` (``{effect: {param:
    {n, mean, sd, min, max, values}}}``); :meth:`spec_for` gives one test's model.

    An ``add`` name that the model already has is *refitted*: its parameters are freed, starting at the values
    the model gave them.
    """

    def __init__(self, add: Sequence[str | Candidate], start: Mapping[str, Mapping[str, float]] | None = None,
                 executor: ExecutorLike = None, max_nfev: int = 40,
                 per_test: Mapping[str, Sequence[str]] | None = None, *, base: object = None):
        if base is not None or isinstance(start, ModelSpec):
            raise TypeError("EffectFit takes the base model in fit(tests, base), as Diagnoser and ForwardSelection "
                            "do: EffectFit(add, ...).fit(tests, base)")
        self.add = list(add)
        self.per_test = {k: list(v) for k, v in (per_test or {}).items()}
        self.start = start
        self.executor = executor
        self.max_nfev = max_nfev

    def _candidates(self) -> list[Candidate]:
        # an effect the model already has is *refitted*: freed, starting at the value the user gave it
        given = {n: dict(v) for n, v in self.base_.effects}
        again = [a for a in self.add if isinstance(a, str) and a in given]
        self.refitted_ = {a: dict(given[a]) for a in again}
        self.fit_base_ = replace(self.base_, effects=tuple(e for e in self.base_.effects if e[0] not in again))
        cands = [refit_candidate(a, given[a], self.base_.specimen) if isinstance(a, str) and a in given
                 else resolve([a], specimen=self.base_.specimen)[0] for a in self.add]
        names = [c.effect for c in cands]
        duplicate = {n for n in names if names.count(n) > 1} | (set(names) & set(self.fit_base_.effect_names))
        if duplicate:
            raise EffectError(f"effect {sorted(duplicate)[0]!r} is already in the model; add each effect once")
        if not cands:
            raise EffectError("nothing to add: give at least one effect name")
        unknown = sorted(set(self.per_test) - set(names))
        if unknown:
            raise EffectError(f"per-test parameters of {unknown[0]!r}: that effect is not fitted (fitted: "
                              f"{', '.join(names)})")
        return [c.with_per_test(self.per_test[c.effect]) if c.effect in self.per_test else c for c in cands]

    def fit(self, tests: Sequence[MeasuredTest], base: ModelSpec | None = None) -> EffectFit:
        """Fit the added effects' parameters on ``tests`` with the model ``base`` (default: case B, reference
        specimen) as the rest of the model."""
        self.base_ = base or ModelSpec()
        cands = self._candidates()
        self.candidates_ = cands
        tests = list(tests)
        with executor_scope(self.executor, len(group_by_force(tests))) as ex:
            mapper = ex.map
            self.baseline_ = discrepancies(evaluate_spec(self.base_, tests, mapper))
            start = None
            if self.start:
                start = tuple(float(self.start.get(c.effect, {}).get(p, c.start_values()[p]))
                              for c in cands for p in c.shared)
            task = FitTask(self.fit_base_, tuple(cands), tuple(tests), (), start, self.max_nfev, "fit")
            self.outcome_ = run_fit(task, mapper)
            self.spec_ = self.fit_base_
            for name, values in self.outcome_.values.items():
                self.spec_ = spec_with_values(self.spec_, name, values)
            self.per_test_ = self.outcome_.per_test
            if self.per_test_:
                from .pertest import evaluate_per_test
                self.discrepancies_ = evaluate_per_test(self.spec_, self.per_test_, tests, mapper)
            else:
                self.discrepancies_ = discrepancies(evaluate_spec(self.spec_, tests, mapper))
        from .evidence import model_form_allowance
        self.bias_ratio_ = model_form_allowance(self.discrepancies_)
        scatter = repeat_scatter_mm(tests, self.base_.rest_positions)
        self.parameters_: dict[str, dict[str, FitParameter]] = {}
        for c in cands:
            starts = c.start_values() if start is None else dict(zip(c.shared, start[:len(c.shared)]))
            self.parameters_[c.effect] = fitted_parameters(c, self.outcome_, starts, len(tests), scatter,
                                                           self.bias_ratio_)
            if start is not None:
                start = start[len(c.shared):]
        self.intervals_: tuple[str, ...] = ()
        if not self.per_test_:       # the profile-likelihood intervals, recorded on the parameters
            found = self._profile(cands, tests, scatter)
            self.parameters_ = {e: {k: replace(p, profile_ci95=tuple(found[e][k])) if found.get(e, {}).get(k)
                                    is not None else p for k, p in ps.items()} for e, ps in self.parameters_.items()}
            self.intervals_ = ("profile",)
        self.effects_: list[Effect] = self.spec_.build_effects()[len(self.fit_base_.effects):]
        self.baseline_error_mm_ = overall_error(self.baseline_)
        self.error_mm_ = overall_error(self.discrepancies_)
        self.baseline_by_load_ = errors_by_load(self.baseline_)
        self.error_by_load_ = errors_by_load(self.discrepancies_)
        from .pertest import summarize
        self.per_test_summary_ = {e: {p: summarize(v) for p, v in ps.items()} for e, ps in self.per_test_.items()}
        return self

    def _profile(self, cands: Sequence[Candidate], tests: Sequence[MeasuredTest],
                 scatter: float) -> dict[str, dict[str, list[float] | None]]:
        """Profile-likelihood intervals (:mod:`~triplanar.workbench.profile`) of the parameters that have a curvature
        interval, with the same standard error and quantile."""
        from .intervals import quantile, standard_error
        from .profile import fitted_profile_intervals
        problem = Problem(self.fit_base_, cands, tests)
        names = problem.names
        se = [standard_error(self.stderr_[e][p], 0.0, self.outcome_.train_error_mm, scatter, self.bias_ratio_)
              if self.ci95_[e].get(p) is not None else math.nan for e, p in names]
        bounds = [(REGISTRY[e].parameters[p].lower, REGISTRY[e].parameters[p].upper) for e, p in names]
        found = fitted_profile_intervals(problem, self.outcome_.vector, se, quantile(len(tests), len(names)), bounds)
        out: dict[str, dict[str, list[float] | None]] = {}
        for (e, p), ci in zip(names, found):
            out.setdefault(e, {})[p] = ci
        return out

    # -- views of ``parameters_`` (the dictionaries of earlier versions, in the same order) ---------------
    @property
    def params_(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: value}}``: held and shared fitted values (per-test ones are in ``per_test_``)."""
        return shared_values(self.parameters_)

    @property
    def stderr_(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: standard error}}`` of the fitted shared parameters (the sandwich, ``fit`` module doc)."""
        return standard_errors(self.parameters_)

    @property
    def ci95_(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}`` of the free parameters (per-test ones: ``None``)."""
        return intervals_of(self.parameters_)

    @property
    def status_(self) -> dict[str, dict[str, str]]:
        """``{effect: {param: status}}`` (:mod:`~triplanar.workbench.parameters`)."""
        return statuses_of(self.parameters_)

    @property
    def profile_ci95_(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}`` of the free parameters, from the profile of the objective
        (:mod:`~triplanar.workbench.profile`); empty with per-test parameters."""
        return profiles_of(self.parameters_) if "profile" in self.intervals_ else {}

    @property
    def at_bound_(self) -> tuple[str, ...]:
        """``effect.param`` of the free parameters fitted to an end of their range (implausible)."""
        return at_bound_of(self.parameters_)

    def spec_for(self, test_id: str) -> ModelSpec:
        """The fitted model of one test (its own values of the per-test parameters; ``spec_`` without any)."""
        from .pertest import spec_for_test
        return spec_for_test(self.spec_, self.per_test_, test_id)

    def error_mm(self, tests: Sequence[MeasuredTest]) -> float:
        """RMS discrepancy of the fitted model on ``tests`` (per-test parameters: each test's own values are
        fitted with the shared ones held, as for held-out tests in diagnose)."""
        if self.per_test_:
            from .pertest import ProfiledProblem
            problem = ProfiledProblem(self.fit_base_, self.candidates_, [], map)
            found = problem.profile(problem.scaled(self.outcome_.vector), list(tests))
            return rms([p.error_mm for p in found])
        return overall_error(discrepancies(evaluate_spec(self.spec_, tests)))

    def score(self, tests: Sequence[MeasuredTest]) -> float:
        """Fraction of the base model's RMS discrepancy on ``tests`` that the fitted effects remove
        (1: perfect, 0: no better, negative: worse). Higher is better, as in scikit-learn."""
        base = overall_error(discrepancies(evaluate_spec(self.base_, tests)))
        return 1.0 - self.error_mm(tests) / base if base > 0 else 0.0

    def predict(self, force_N: float, travel_m: float = 0.08) -> SimulationResult:
        """Simulate the fitted model at ``force_N``."""
        from ..simulate import simulate
        return simulate(self.spec_.build(force_N), travel_m=travel_m)
