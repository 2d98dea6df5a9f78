"""Per-test parameters: fitted for each test, the other parameters shared by all tests (profiling).

A parameter declared per test (``Parameter(..., per_test=True)`` on the effect, ``Candidate.per_test``,
``EffectFit(per_test=...)``, CLI ``--per-test NAME:PARAM``) takes its own value in every test, as the phase of a
ripple that is not locked to the actuator's start does. The shared parameters ``theta`` are fitted on the
*profiled* objective::

    cost(theta) = sum over tests t of  min over phi_t of  |r_t(theta, phi_t)|^2

For given shared values, each test's own values ``phi_t`` are fitted alone (:func:`profile_test`: a test is one
simulation at its own force, and its own few parameters; a scan of their grid the first time, then least
squares warm-started from the last profile). The tests' profiles are independent tasks mapped over the
executor (:func:`triplanar.executor.run_tasks`' backends through the problem's ``mapper``).

The outer fit (``scipy.optimize.least_squares``, trust-region reflective, shared parameters scaled to [0, 1])
is given the Jacobian of the profiled residuals by variable projection (Golub-Pereyra with Kaufman's
approximation): per test, ``(I - J_phi J_phi^+) J_theta``, both parts by forward differences at the test's
profile. The same projected Jacobian feeds the cluster-robust sandwich (one cluster per test), so the shared
parameters' standard errors account for what the per-test values absorb; the intervals are then made as for any
fit (:mod:`triplanar.workbench.intervals`: jackknife over folds in diagnose, the model-form factor).

Held-out tests (cross-validation) get their own per-test values fitted with the shared values held at the
training fit's: a per-test value is a property of the test, not of the load, so only the shared part is judged
on loads it was not fitted to.

Per-test values have no intervals (each is fitted to one trace, whose samples are strongly correlated); the
reports give each test's value and their summary (``summarize``).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from ..measurement import MeasuredTest
from .candidates import Candidate
from .discrepancy import TestDiscrepancy
from .fitbase import DIFF_STEP, FitOutcome, ScaledBox, cluster_robust_stderr, safe_evaluate
from .spec import EvalTask, ModelSpec, spec_with_values

#: Least-squares evaluations of one test's profile (warm-started ones converge in 3-6).
INNER_NFEV = 20


def _layout(candidates: Sequence[Candidate]) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    shared = [(i, p) for i, c in enumerate(candidates) for p in c.shared]
    per = [(i, p) for i, c in enumerate(candidates) for p in c.per_test]
    return shared, per


def has_per_test(candidates: Sequence[Candidate]) -> bool:
    return any(c.per_test for c in candidates)


def spec_at(base: ModelSpec, candidates: Sequence[Candidate], shared: Sequence[float],
            phi: Sequence[float]) -> ModelSpec:
    """``base`` plus every candidate at the shared values ``shared`` and one test's values ``phi`` (natural)."""
    s_names, p_names = _layout(candidates)
    free: list[dict[str, float]] = [{} for _ in candidates]
    for (i, p), v in zip(s_names, shared):
        free[i][p] = float(v)
    for (i, p), v in zip(p_names, phi):
        free[i][p] = float(v)
    spec = base
    for c, values in zip(candidates, free):
        spec = spec_with_values(spec, c.effect, c.values(values))
    return spec


def _evaluate_one(spec: ModelSpec, test: MeasuredTest, report: bool = False) -> TestDiscrepancy:
    return safe_evaluate(EvalTask(spec, float(test.shear_force_N), (test,), report=report)).discrepancies[0]


@dataclass(frozen=True)
class TestProfileTask:
    """One test's profile: fit its per-test values at the given shared values (``solve``), and/or the partial
    Jacobians there (``jacobian``). Picklable: the unit mapped over the executor."""

    __test__ = False

    base: ModelSpec
    candidates: tuple[Candidate, ...]
    shared: tuple[float, ...]                    # natural shared values
    test: MeasuredTest
    phi: tuple[float, ...] | None = None         # natural per-test start (None: scan the grid)
    solve: bool = True
    jacobian: bool = False
    shared_bounds: tuple[tuple[float, float], ...] = ()
    max_nfev: int = INNER_NFEV


@dataclass(frozen=True)
class TestProfile:
    """What :func:`profile_test` returns (``jac_shared``/``jac_phi``: d residuals / d natural values)."""

    __test__ = False

    test_id: str
    force_N: float
    phi: tuple[float, ...]
    residuals: np.ndarray
    error_mm: float
    nfev: int
    jac_shared: np.ndarray | None = None
    jac_phi: np.ndarray | None = None


def profile_test(task: TestProfileTask) -> TestProfile:
    """Fit one test's per-test values (module doc), pure."""
    cands = task.candidates
    _, p_names = _layout(cands)
    lo = np.array([cands[i].bounds[p][0] for i, p in p_names], dtype=float)
    hi = np.array([cands[i].bounds[p][1] for i, p in p_names], dtype=float)
    period = np.array([_period(cands[i], p) for i, p in p_names], dtype=float)
    wrap = np.isfinite(period)
    if wrap.any():  # a periodic parameter moves freely over one period centred on its fit range
        mid = 0.5 * (lo + hi)
        lo = np.where(wrap, mid - 0.5 * period, lo)
        hi = np.where(wrap, mid + 0.5 * period, hi)
    u_lo = np.where(wrap, -np.inf, 0.0)
    u_hi = np.where(wrap, np.inf, 1.0)
    cache: dict[tuple, TestDiscrepancy] = {}
    count = [0]

    def found_at(shared: Sequence[float], phi: np.ndarray) -> TestDiscrepancy:
        key = (tuple(np.round(shared, 12)), tuple(np.round(phi, 12)))
        if key not in cache:
            count[0] += 1
            cache[key] = _evaluate_one(spec_at(task.base, cands, shared, phi), task.test)
        return cache[key]

    def natural(u: np.ndarray) -> np.ndarray:
        return lo + np.where(wrap, np.mod(u, 1.0), np.clip(u, 0.0, 1.0)) * (hi - lo)

    def residuals(u: np.ndarray) -> np.ndarray:
        return found_at(task.shared, natural(u)).residuals

    if task.phi is not None:
        u = np.clip((np.asarray(task.phi, dtype=float) - lo) / (hi - lo), 0.0, 1.0)
    else:
        u = np.zeros(len(p_names))
    if task.solve:
        if task.phi is None:
            grids = [sorted({*cands[i].per_test_grid_values(p, periodic=bool(w)), cands[i].start_values()[p]})
                     for (i, p), w in zip(p_names, wrap)]
            points = [np.clip((np.array(point, dtype=float) - lo) / (hi - lo), 0.0, 1.0)
                      for point in itertools.product(*grids)]
            costs = [float(np.sum(residuals(p) ** 2)) for p in points]
            u = points[int(np.argmin(costs))]
        res = least_squares(residuals, u, bounds=(u_lo, u_hi), method="trf", diff_step=DIFF_STEP, x_scale=1.0,
                            max_nfev=task.max_nfev, ftol=1e-4, xtol=1e-3, gtol=1e-10)
        if float(np.sum(res.fun ** 2)) <= float(np.sum(residuals(u) ** 2)):
            u = res.x
        u = np.where(wrap, np.mod(u, 1.0), u)
    phi = natural(u)
    here = found_at(task.shared, phi)
    jac_shared = jac_phi = None
    if task.jacobian:
        r0 = here.residuals
        cols = []
        for k, (a, b) in enumerate(task.shared_bounds):
            h = DIFF_STEP * (b - a)
            x = list(task.shared)
            x[k] = x[k] + h if x[k] + h <= b else x[k] - h
            step = x[k] - task.shared[k]
            cols.append((found_at(x, phi).residuals - r0) / step)
        jac_shared = np.stack(cols, axis=1) if cols else np.zeros((len(r0), 0))
        cols = []
        for j in range(len(p_names)):
            h = DIFF_STEP * (hi[j] - lo[j])
            y = phi.copy()
            y[j] = y[j] + h if (y[j] + h <= hi[j] or wrap[j]) else y[j] - h
            cols.append((found_at(task.shared, y).residuals - r0) / (y[j] - phi[j]))
        jac_phi = np.stack(cols, axis=1) if cols else np.zeros((len(r0), 0))
    return TestProfile(here.test_id, here.force_N, tuple(float(v) for v in phi), here.residuals, here.error_mm,
                       count[0], jac_shared, jac_phi)


def _period(cand: Candidate, name: str) -> float:
    from ..effects import REGISTRY
    period = REGISTRY[cand.effect].parameters[name].period
    return math.inf if period is None else float(period)


def projected(jac_shared: np.ndarray, jac_phi: np.ndarray) -> np.ndarray:
    """Kaufman's variable-projection Jacobian of one test: ``(I - J_phi J_phi^+) J_shared``."""
    if jac_phi.shape[1] == 0 or jac_shared.shape[1] == 0:
        return jac_shared
    coef = np.linalg.lstsq(jac_phi, jac_shared, rcond=1e-10)[0]
    return jac_shared - jac_phi @ coef


class ProfiledProblem(ScaledBox):
    """The outer problem over the shared parameters (scaled to [0, 1]); residuals are the tests' profiled
    residuals. Keeps each test's latest profile at the best point seen (the warm start of the next)."""

    def __init__(self, base: ModelSpec, candidates: Sequence[Candidate], tests: Sequence[MeasuredTest],
                 mapper: Callable = map, phi_start: Mapping[str, Sequence[float]] | None = None):
        self.base, self.candidates, self.tests, self.mapper = base, tuple(candidates), list(tests), mapper
        s_names, p_names = _layout(self.candidates)
        self.names = [(self.candidates[i].effect, p) for i, p in s_names]
        self.per_test_names = [(self.candidates[i].effect, p) for i, p in p_names]
        self.lo = np.array([self.candidates[i].bounds[p][0] for i, p in s_names], dtype=float)
        self.hi = np.array([self.candidates[i].bounds[p][1] for i, p in s_names], dtype=float)
        self.phi: dict[str, tuple[float, ...]] = {k: tuple(v) for k, v in (phi_start or {}).items()}
        self.best_cost = math.inf
        self.profiles: dict[tuple, list[TestProfile]] = {}
        self.nfev = 0
        self.simulations = 0

    def start(self, warm: Mapping[str, Mapping[str, float]] | None = None) -> np.ndarray:
        warm = warm or {}
        return self.scaled([float(warm.get(c.effect, {}).get(p, c.start_values()[p]))
                            for c in self.candidates for p in c.shared])

    def _tasks(self, x: np.ndarray, tests: Sequence[MeasuredTest], solve: bool, jacobian: bool,
               phis: Mapping[str, tuple[float, ...]]) -> list[TestProfileTask]:
        bounds = tuple((float(a), float(b)) for a, b in zip(self.lo, self.hi))
        return [TestProfileTask(self.base, self.candidates, tuple(float(v) for v in x), t, phis.get(t.test_id),
                                solve, jacobian, bounds) for t in tests]

    def profile(self, u: np.ndarray, tests: Sequence[MeasuredTest] | None = None) -> list[TestProfile]:
        """Every test's profile at scaled shared values ``u`` (cached per ``u`` for the problem's own tests)."""
        own = tests is None
        key = tuple(np.round(np.asarray(u, dtype=float), 12))
        if own and key in self.profiles:
            return self.profiles[key]
        tests = self.tests if own else list(tests)
        out = list(self.mapper(profile_test, self._tasks(self.natural(u), tests, True, False, self.phi if own else {})))
        self.simulations += sum(p.nfev for p in out)
        if own:
            self.nfev += 1
            self.profiles[key] = out
            cost = float(sum(np.sum(p.residuals ** 2) for p in out))
            if cost < self.best_cost:
                self.best_cost = cost
                self.phi = {p.test_id: p.phi for p in out}
        return out

    def residuals(self, u: np.ndarray) -> np.ndarray:
        return np.concatenate([p.residuals for p in self.profile(u)])

    def jacobians(self, u: np.ndarray) -> list[TestProfile]:
        """Each test's partial Jacobians at its profile at ``u`` (natural units)."""
        profiles = self.profile(u)
        phis = {p.test_id: p.phi for p in profiles}
        out = list(self.mapper(profile_test, self._tasks(self.natural(u), self.tests, False, True, phis)))
        self.simulations += sum(p.nfev for p in out)
        return out

    def projected_jacobian(self, u: np.ndarray) -> np.ndarray:
        """d profiled residuals / d natural shared values (variable projection), stacked over tests."""
        return np.concatenate([projected(p.jac_shared, p.jac_phi) for p in self.jacobians(u)], axis=0)

    def jac(self, u: np.ndarray) -> np.ndarray:
        """For the solver: d residuals / d scaled values."""
        return self.projected_jacobian(u) * (self.hi - self.lo)[None, :]


def sandwich(problem: ProfiledProblem, u: np.ndarray) -> np.ndarray:
    """Cluster-robust (one cluster per test) standard errors of the shared values (natural units), from the
    projected Jacobian: what the per-test values absorb does not count as information on the shared ones."""
    profiles = problem.profile(u)
    parts = problem.jacobians(u)
    jn = [projected(p.jac_shared, p.jac_phi) for p in parts]
    if not jn:
        return np.full(problem.n, math.inf)
    return cluster_robust_stderr(jn, [prof.residuals for prof in profiles])


def solve_profiled(problem: ProfiledProblem, start: Sequence[float] | None = None, max_nfev: int = 30,
                   warm: Mapping[str, Mapping[str, float]] | None = None):
    """Bounded least squares over the shared values (from ``start``, natural, else the warm/neutral start; no
    grid scan of shared values: every point of it would cost a profile of every test). Returns (u, message)."""
    u0 = problem.scaled(start) if start is not None else problem.start(warm)
    if problem.n == 0:
        problem.profile(u0)
        return u0, "no shared parameter: every test profiled once"
    # The solver works on u + 1, in [1, 2]: its first trust region is |x0|, which would be nil for a shared
    # parameter starting at its neutral lower bound (no grid scan moves it off first, as in the other fits).
    res = least_squares(lambda v: problem.residuals(v - 1.0), u0 + 1.0, jac=lambda v: problem.jac(v - 1.0),
                        bounds=(1.0, 2.0), method="trf", x_scale=1.0, max_nfev=max_nfev, ftol=1e-4, xtol=1e-3,
                        gtol=1e-8)
    u = np.clip(res.x - 1.0, 0.0, 1.0)
    if float(np.sum(problem.residuals(u) ** 2)) > float(np.sum(problem.residuals(u0) ** 2)):
        u = u0
    return u, res.message


def run_profiled_fit(task, mapper: Callable = map):
    """:func:`triplanar.workbench.fit.run_fit` for candidates with per-test parameters (module doc)."""
    began = time.perf_counter()
    problem = ProfiledProblem(task.base, task.candidates, task.train, mapper, getattr(task, "phi_start", None))
    u, message = solve_profiled(problem, task.start, task.max_nfev, task.warm)
    neutral = problem.start()
    u = np.where(np.abs(u - neutral) < 1e-6, neutral, u)
    x = problem.natural(u)
    profiles = problem.profile(u)
    stderr = sandwich(problem, u) if problem.n else np.zeros(0)
    held: dict[str, tuple[float, float]] = {}
    held_profiles: list[TestProfile] = []
    if task.held_out:
        held_profiles = problem.profile(u, task.held_out)
        held = {p.test_id: (p.force_N, p.error_mm) for p in held_profiles}
    values: dict[str, dict[str, float]] = {}
    shared_iter = iter(x)
    for c in task.candidates:
        shared = {p: float(next(shared_iter)) for p in c.shared}
        own = {p: c.start_values()[p] for p in c.per_test}
        values[c.effect] = {k: v for k, v in c.values({**shared, **own}).items() if k not in c.per_test}
    errs: dict[str, dict[str, float]] = {}
    for (effect, param), se in zip(problem.names, stderr):
        errs.setdefault(effect, {})[param] = float(se)
    per_test: dict[str, dict[str, dict[str, float]]] = {}
    for prof in [*profiles, *held_profiles]:
        for (effect, param), v in zip(problem.per_test_names, prof.phi):
            per_test.setdefault(effect, {}).setdefault(param, {})[prof.test_id] = float(v)
    at_bound = problem.at_bound(u, neutral)
    train_errors = {p.test_id: (p.force_N, p.error_mm) for p in profiles}
    return FitOutcome(task.label, tuple(c.effect for c in task.candidates), values, errs, at_bound,
                      overall_error_from(train_errors), train_errors, held, problem.nfev,
                      time.perf_counter() - began, f"{message} ({problem.simulations} simulations)",
                      tuple(float(v) for v in x), per_test)


def overall_error_from(errors: Mapping[str, tuple[float, float]]) -> float:
    from .discrepancy import rms
    return rms([e for _, e in errors.values()])


def with_values(spec: ModelSpec, name: str, values: Mapping[str, float]) -> ModelSpec:
    """``spec`` with effect ``name``'s parameters ``values`` changed (the effect must be in the spec)."""
    effects = []
    for effect, params in spec.effects:
        if effect == name:
            merged = {**dict(params), **{k: float(v) for k, v in values.items()}}
            params = tuple(sorted(merged.items()))
        effects.append((effect, params))
    from dataclasses import replace
    return replace(spec, effects=tuple(effects))


def spec_for_test(spec: ModelSpec, per_test: Mapping[str, Mapping[str, Mapping[str, float]]],
                  test_id: str) -> ModelSpec:
    """``spec`` (the shared fit) with test ``test_id``'s own values of the per-test parameters."""
    for effect, params in per_test.items():
        mine = {p: by_test[test_id] for p, by_test in params.items() if test_id in by_test}
        if mine:
            spec = with_values(spec, effect, mine)
    return spec


def evaluate_per_test(spec: ModelSpec, per_test: Mapping[str, Mapping[str, Mapping[str, float]]],
                      tests: Sequence[MeasuredTest], mapper: Callable = map) -> list[TestDiscrepancy]:
    """Discrepancies of every test against ``spec`` with its own per-test values (one simulation per test;
    tests without values are evaluated with ``spec`` as it is)."""
    tasks = [EvalTask(spec_for_test(spec, per_test, t.test_id), float(t.shear_force_N), (t,)) for t in tests]
    return [r.discrepancies[0] for r in mapper(safe_evaluate, tasks)]


def summarize(values: Mapping[str, float]) -> dict:
    """Each test's value and their summary: ``n``, ``mean``, ``sd``, ``min``, ``max`` (a phase's mean is not its
    circular mean: read ``values`` for that)."""
    v = np.array(list(values.values()), dtype=float)
    if v.size == 0:
        return {"n": 0, "mean": None, "sd": None, "min": None, "max": None, "values": {}}
    return {"n": int(v.size), "mean": float(v.mean()), "sd": float(v.std(ddof=1)) if v.size > 1 else 0.0,
            "min": float(v.min()), "max": float(v.max()), "values": {k: float(x) for k, x in values.items()}}


def describe(name: str, summary: Mapping) -> str:
    """One line for a per-test parameter: ``name per test (n values: mean m, sd s, range [a, b])``."""
    if not summary.get("n"):
        return f"{name} per test (no values)"
    return (f"{name} per test ({summary['n']} values: mean {summary['mean']:.4g}, sd {summary['sd']:.3g}, "
            f"range [{summary['min']:.4g}, {summary['max']:.4g}])")
