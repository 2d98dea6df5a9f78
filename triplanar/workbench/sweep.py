"""The unit of work of a diagnosis: one candidate's cross-validated fit (:func:`run_candidate`) and its line of
the report (:class:`CandidateResult`, :func:`assemble`).

Folds are load levels, interleaved (fold k holds levels k, k+K, k+2K, ... of the sorted loads), so a candidate is
judged on loads it was not fitted to. Every (candidate, fold) fit is an independent
:class:`~triplanar.workbench.fit.FitTask`; :func:`run_candidate` runs one candidate's fits and is what
:class:`~triplanar.workbench.diagnose.Diagnoser` maps over its executor.

``param_stderr``: the larger of the cluster-robust sandwich error of the full fit and the delete-a-fold jackknife
over the cross-validation fits (which also sees a parameter drifting with load); the 95 % intervals are
:func:`~triplanar.workbench.intervals.interval95`'s.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, Mapping, Sequence

import numpy as np

from ..effects import REGISTRY
from ..measurement import MeasuredTest
from .candidate_result import CandidateResult, CandidateTask
from .candidates import Candidate, without_effect
from .discrepancy import TestDiscrepancy, rms
from .fit import FitOutcome, FitTask, discrepancies, evaluate_spec, run_fit
from . import rules
from .intervals import form_allowance, interval95
from .parameters import EffectParameters
from .spec import ModelSpec, spec_with_values

def load_folds(forces: Sequence[float], k: int) -> list[list[float]]:
    """Interleaved folds of the sorted load levels (at most one fold per level)."""
    levels = sorted(set(float(f) for f in forces))
    k = max(1, min(k, len(levels)))
    return [levels[i::k] for i in range(k)]


def jackknife(folds: list[dict[str, float]]) -> dict[str, float]:
    k = len(folds)
    if k < 2:
        return {}
    out = {}
    for name in folds[0]:
        values = np.array([f[name] for f in folds])
        out[name] = float(math.sqrt((k - 1) / k * np.sum((values - values.mean()) ** 2)))
    return out


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



def assemble(task: CandidateTask, by_label: dict[str, FitOutcome], k: int, n_tests: int, baseline_mm: float,
             scatter_mm: float) -> CandidateResult:
    """One candidate's line of the report from its fits (``by_label["KEY/all"]``, ``"KEY/fold0"``, ...): cross-validated
    error, parameters with their standard errors and 95 % intervals, and those of the effects refitted with it."""
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
    jack = jackknife(fold_params) if k > 1 else {}
    stderr = {p: float(max(sandwich.get(p, 0.0), jack.get(p, 0.0))) for p in cand.shared}
    base = baseline_mm
    improvement = 1.0 - cv / base if base > 0 and math.isfinite(cv) else 0.0
    implausible = [a.split(".", 1)[1] for a in full.at_bound if a.split(".", 1)[0] == cand.effect]
    seconds = full.seconds + sum(by_label[f"{task.key}/fold{i}"].seconds for i in range(k))
    nfev = full.nfev + sum(by_label[f"{task.key}/fold{i}"].nfev for i in range(k))
    start = cand.start_values()
    recipe = cand.parameters()
    ci, status = {}, {}
    for p in cand.shared:
        lo, hi = REGISTRY[cand.effect].parameters[p].lower, REGISTRY[cand.effect].parameters[p].upper
        allowance = form_allowance(params[p], start[p], base, full.train_error_mm, rules.form_tolerance_mm(cand.effect))
        ci[p], status[p] = interval95(params[p], sandwich.get(p, math.nan), jack.get(p, 0.0), n_tests,
                                      len(cand.shared), full.train_error_mm, scatter_mm,
                                      (lo, hi), start[p], cand.bounds[p], full.bias_ratio, allowance)
        if p in implausible and ci[p] is not None:   # (without an interval its status says why)
            status[p] = "at_bound"
    # the effects refitted jointly with it (forward selection, combinations): their intervals the same way
    found = {cand.effect: (ci, status)}
    n_free = len(cand.shared) + sum(len(r.shared) for r in task.refit)
    for other in task.refit:
        folds_other = [by_label[f"{task.key}/fold{i}"].values[other.effect] for i in range(k)]
        jack_other = jackknife([{p: f[p] for p in other.shared} for f in folds_other]) if k > 1 else {}
        found[other.effect] = ({}, {})
        for p in other.shared:
            par = REGISTRY[other.effect].parameters[p]
            found[other.effect][0][p], found[other.effect][1][p] = interval95(
                full.values[other.effect][p], full.stderr.get(other.effect, {}).get(p, math.nan),
                jack_other.get(p, 0.0), n_tests, n_free, full.train_error_mm, scatter_mm,
                (par.lower, par.upper), math.nan, other.bounds[p], full.bias_ratio)
    given = dict(cand.start or {}) if task.kind in ("refit", "given") else {}
    parameters = {p: replace(recipe[p], value=params[p], start=start[p], stderr=stderr[p],
                             ci95=tuple(ci[p]) if ci[p] is not None else None, status=status[p],
                             at_bound=p in implausible) for p in cand.shared}
    return CandidateResult(cand.effect, parameters, cv, full.train_error_mm, improvement, not implausible,
                           implausible, {f: rms(v) for f, v in sorted(by_load.items())}, fold_params, seconds, nfev,
                           joint=joint_parameters((cand, *task.refit), full, found), kind=task.kind, given=given,
                           held_out_mm={t: e for t, (_, e) in held.items()}, bias_ratio=full.bias_ratio)


def joint_parameters(cands: Sequence[Candidate], full: FitOutcome,
                     found: Mapping[str, tuple[Mapping[str, Sequence[float] | None], Mapping[str, str]]]
                     ) -> EffectParameters:
    """Every effect of a joint fit as FitParameter objects (:attr:`CandidateResult.joint`): each parameter of its
    recipe in the fit's order (held ones, then the free ones), with the value and sandwich standard error of the fit
    on all tests (``full``) and the interval and status ``found`` for its shared ones (``{effect: (ci95, status)}``);
    then its per-test parameters, with their value in each test (``per_test_values``; their ``value`` is the start)."""
    out: EffectParameters = {}
    for c in cands:
        recipe = c.parameters()
        errs = full.stderr.get(c.effect, {})
        ci, status = found.get(c.effect, ({}, {}))
        out[c.effect] = {k: replace(recipe[k], value=float(v), stderr=errs.get(k) if recipe[k].vary else None,
                                    ci95=tuple(ci[k]) if ci.get(k) is not None else None,
                                    status=status.get(k, recipe[k].status if not recipe[k].vary else "fitted"),
                                    at_bound=f"{c.effect}.{k}" in full.at_bound)
                         for k, v in full.values.get(c.effect, {}).items()}
        out[c.effect].update({k: replace(recipe[k], status="per_test", at_bound=f"{c.effect}.{k}" in full.at_bound,
                                         per_test_values=dict(full.per_test[c.effect][k]))
                              for k in c.per_test if k in full.per_test.get(c.effect, {})})
    return out


def profile_result(task: CandidateTask, result: CandidateResult, tests: Sequence[MeasuredTest], scatter_mm: float,
                   mapper: Callable = map) -> None:
    """Record the profile-likelihood intervals (:mod:`~triplanar.workbench.profile`) of the candidate's own
    parameters on ``result`` (``param_profile_ci95``) for those that have a curvature interval, with the same standard error and quantile (the effects refitted with it are
    profiled over, not reported). Candidates with per-test parameters get none."""
    if result.per_test:
        return
    from .fit import Problem
    from .intervals import quantile, standard_error
    from .profile import fitted_profile_intervals
    cands = (task.candidate, *task.refit)
    problem = Problem(task.base, cands, list(tests), mapper)
    own = task.candidate.shared
    vector = [result.all_values[c.effect][p] for c in cands for p in c.shared]
    se = [standard_error(result.param_stderr[p], 0.0, result.fit_error_mm, scatter_mm, result.bias_ratio)
          if result.param_ci95.get(p) is not None else math.nan for p in own] + [math.nan] * (problem.n - len(own))
    bounds = [(REGISTRY[e].parameters[p].lower, REGISTRY[e].parameters[p].upper) for e, p in problem.names]
    found = fitted_profile_intervals(problem, vector, se, quantile(len(tests), len(own)), bounds, only=len(own))
    result.set_intervals("profile", dict(zip(own, found)))


def spec_of(user_base: ModelSpec, result: CandidateResult) -> ModelSpec:
    """The model ``user_base`` with ``result``'s entry at its fitted values (a refit replaces the given effect), and
    the effects fitted jointly with it at theirs."""
    spec = user_base
    if result.kind == "refit":
        spec = replace(spec, effects=without_effect(spec.effects, result.effect))
    for name, values in result.all_values.items():
        if name != result.effect:
            spec = spec_with_values(spec, name, values)
    return spec_with_values(spec, result.effect, result.all_values[result.effect])


def residual_of(user_base: ModelSpec, result: CandidateResult, tests: Sequence[MeasuredTest]) -> list[TestDiscrepancy]:
    """The per-test discrepancies of ``user_base`` with ``result``'s entry (each test's own values of per-test
    parameters)."""
    spec = spec_of(user_base, result)
    if result.per_test_values:
        from .pertest import evaluate_per_test
        return evaluate_per_test(spec, result.per_test_values, tests)
    return discrepancies(evaluate_spec(spec, tests))
