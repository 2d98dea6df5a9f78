"""What a joint fit (:mod:`triplanar.workbench.fit`) and a profiled per-test fit (:mod:`triplanar.workbench.pertest`)
share: the scaled box of free parameters, a fit's outcome, the at-bound threshold, and an evaluation that never
raises. Both fits import it; neither imports the other at import time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Sequence

import numpy as np

from .discrepancy import NO_RUN, NoRun, discrepancy_group, rms
from .spec import EvalResult, EvalTask, evaluate

#: A free parameter at most this fraction of its range from a bound is "at the bound" (implausible).
AT_BOUND = 0.01
#: Finite-difference step, as a fraction of each parameter's fit range (every fit's, and the profiles').
DIFF_STEP = 2e-3


def safe_evaluate(task: EvalTask) -> EvalResult:
    """:func:`evaluate`, but a model the core refuses (e.g. a plane tilt that moves a contact point too far
    off its plane) counts as a block that never moves, with the reason in ``message``."""
    try:
        return evaluate(task)
    except (ValueError, ArithmeticError) as err:
        rest = NoRun(task.spec.rest_positions, f"model refused: {err}")
        found = tuple(discrepancy_group(task.tests, rest))
        return EvalResult(task.force_N, NO_RUN, rest.message, found)


@dataclass(frozen=True)
class FitOutcome:
    """The result of one fit. ``values``/``stderr``: ``{effect: {param: value}}``; ``train_errors`` and
    ``held_out_errors``: ``{test_id: (force_N, error_mm)}``; ``per_test``: ``{effect: {param: {test_id: value}}}``
    for per-test parameters (training and held-out tests; :mod:`triplanar.workbench.pertest`), whose values are
    then absent from ``values``; ``vector``: the shared free values."""

    label: str
    effects: tuple[str, ...]
    values: dict[str, dict[str, float]]
    stderr: dict[str, dict[str, float]]
    at_bound: tuple[str, ...]
    train_error_mm: float
    train_errors: dict[str, tuple[float, float]]
    held_out_errors: dict[str, tuple[float, float]]
    nfev: int
    seconds: float
    message: str
    vector: tuple[float, ...] = field(default=(), repr=False)
    per_test: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    bias_ratio: float = 1.0     # evidence.bias_ratio of the fitted model on its training tests (diagnose's full fit)

    @property
    def held_out_error_mm(self) -> float:
        return rms([e for _, e in self.held_out_errors.values()])


class ScaledBox:
    """Free parameters ``names`` scaled to [0, 1] over their fitting bounds ``lo``-``hi``: the optimisers work in
    the scaled box (a joint fit, ``fit.Problem``, and a profiled one, ``pertest.ProfiledProblem``)."""

    names: list[tuple[str, str]]
    lo: np.ndarray
    hi: np.ndarray

    @property
    def n(self) -> int:
        return len(self.names)

    def natural(self, u: np.ndarray) -> np.ndarray:
        return self.lo + np.clip(u, 0.0, 1.0) * (self.hi - self.lo)

    def scaled(self, x: Sequence[float]) -> np.ndarray:
        return np.clip((np.asarray(x, dtype=float) - self.lo) / (self.hi - self.lo), 0.0, 1.0)

    def at_bound(self, u: np.ndarray, neutral: np.ndarray) -> tuple[str, ...]:
        """``effect.param`` of the parameters fitted to an end of their range (implausible): not those resting at
        their neutral start (a parameter at "no effect", e.g. phi = 0, just does nothing), nor those at an end the
        effect declares a physical limit (``Parameter.limit_ends``: the model cannot go past it, e.g. a contact point
        leaving its plane, so a fit resting there says the value is at or near that limit, not beyond what is
        physical)."""
        from ..effects import REGISTRY
        out = []
        for (effect, param), ui, u0, lo, hi in zip(self.names, u, neutral, self.lo, self.hi):
            end = "lower" if ui <= AT_BOUND else "upper" if ui >= 1 - AT_BOUND else None
            if end is None or abs(ui - u0) <= AT_BOUND:
                continue
            declared = REGISTRY[effect].parameters.get(param) if effect in REGISTRY else None
            if declared is not None and declared.at_physical_limit(lo + ui * (hi - lo), AT_BOUND):
                continue
            out.append(f"{effect}.{param}")
        return tuple(out)


def cluster_robust_stderr(jacobians: Sequence[np.ndarray], residuals: Sequence[np.ndarray]) -> np.ndarray:
    """Standard errors of a least-squares fit with one cluster per test (``jacobians[t]``: d residuals / d parameters
    of test t, natural units; ``residuals[t]``: its residuals at the optimum), CR3: the delete-one-test jackknife in
    closed form. Each test's residuals are taken as they would be had the fit not seen it, ``(I - H_tt)^-1 r_t`` with
    ``H_tt = J_t (J'J)^-1 J_t'`` (Woodbury: only p x p matrices), times ``(G - 1) / G``. With the dozen tests of a small
    campaign the plain sandwich (CR1) is too narrow: its 95 % intervals held 8 deg of end friction in 24 of 30 clean
    datasets of 12 tests (``benchmarks/interval_coverage.py``), and with per-test offsets in 26 of 30 (6 tests).
    Infinite with no more tests than parameters (no degrees of freedom left for the scatter)."""
    g_n = len(jacobians)
    p = jacobians[0].shape[1] if g_n else 0
    if g_n <= p:
        return np.full(p, math.inf)
    bread = sum(j.T @ j for j in jacobians)
    inv = np.linalg.pinv(bread)
    meat = np.zeros((p, p))
    for j, r in zip(jacobians, residuals):
        a = j.T @ j
        g = j.T @ r
        try:
            g = g + a @ np.linalg.solve(bread - a, g)
        except np.linalg.LinAlgError:
            pass
        meat += np.outer(g, g)
    return np.sqrt(np.clip(np.diag(inv @ meat @ inv * ((g_n - 1) / g_n)), 0.0, None))
