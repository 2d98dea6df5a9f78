"""Profile-likelihood 95 % intervals beside the curvature (sandwich) ones: the shape of the objective, not its
curvature at the optimum.

The reference method is lmfit's ``conf_interval``: fix one parameter at a trial value, refit the others, and
compare the objective with the best fit's (an F-test, ``(chi2_f / chi2_0 - 1) (N - P) / 1``), moving the trial value
until the difference is just significant. Here that test would count every sample of a trace as independent (a
trace's samples are strongly correlated; tests are the independent units), and its interval would be far too
narrow. So the profile's rise is *calibrated* instead (a vertical adjustment of the profile, Chandler & Bate 2007,
Biometrika 94: 167-183): with ``S(theta)`` the sum of squared residuals with the parameter fixed at ``theta`` and
the others refitted, and ``c`` the Gauss-Newton curvature variance ``[(J'J)^-1]_ii`` at the optimum,

    W(theta) = (S(theta) - S_min) * c / se^2,

where ``se`` is the standard error the curvature interval uses (the sandwich or jackknife, whichever is larger,
times the model-form allowance: :func:`triplanar.workbench.intervals.standard_error`). The profile interval is
``{theta : W(theta) <= q^2}`` with the same ``q = t(0.975, n_tests - p)``. Where the objective is quadratic in the
parameter (the model linear in it), ``W = ((theta - theta_hat) / se)^2`` and the two intervals agree; where it is not
(a parameter whose effect saturates, or grows faster than linearly), the profile interval is asymmetric and the
curvature interval is the approximation. The ends are found by bracketing and Brent's method, clipped to the
parameter's physical bounds (an end the objective never reaches within them is that bound).

Each trial value costs one simulation of every test (one parameter) or a small refit of the others (several):
diagnose computes it for the named entries only, ``fit`` for its fit.
"""

from __future__ import annotations

import math
from typing import Callable, Protocol, Sequence

import numpy as np
from scipy.optimize import brentq, least_squares

from .fitbase import DIFF_STEP



class Problem(Protocol):
    """What a profile reads of a fit's problem (:class:`~triplanar.workbench.fit.Problem` is one): the scaled box of
    its parameters (``lo``, ``hi``, ``n``, ``natural``, ``scaled``) and its residual function of the scaled vector.
    A protocol, so that the fit, which computes profiles, and this module do not import each other."""

    lo: np.ndarray
    hi: np.ndarray

    @property
    def n(self) -> int: ...

    def natural(self, u: np.ndarray) -> np.ndarray: ...

    def scaled(self, x: Sequence[float]) -> np.ndarray: ...

    def residuals(self, u: np.ndarray) -> np.ndarray: ...

#: Refit evaluations allowed at each trial value of a parameter (the other parameters, warm-started).
PROFILE_NFEV = 8
#: Brent's method's tolerance on the interval's end, as a fraction of the standard error.
END_TOL = 0.02


class Profile:
    """The profile of ``problem``'s objective along its ``index``-th parameter, from the optimum ``u_hat`` (scaled)."""

    def __init__(self, problem: Problem, u_hat: np.ndarray, index: int):
        self.problem, self.index = problem, index
        self.u_hat = np.asarray(u_hat, dtype=float)
        self.rest = [k for k in range(problem.n) if k != index]
        self.s_min = self.objective(float(problem.natural(self.u_hat)[index]))

    def objective(self, value: float) -> float:
        """Sum of squared residuals with the parameter at ``value`` (natural units) and the others refitted."""
        p, i = self.problem, self.index
        u = self.u_hat.copy()
        u[i] = float(np.clip((value - p.lo[i]) / (p.hi[i] - p.lo[i]), 0.0, 1.0))
        if self.rest:
            def residuals(v: np.ndarray) -> np.ndarray:
                w = u.copy()
                w[self.rest] = v
                return p.residuals(w)
            res = least_squares(residuals, u[self.rest], bounds=(0.0, 1.0), method="trf", diff_step=DIFF_STEP,
                                max_nfev=PROFILE_NFEV, ftol=1e-4, xtol=1e-3)
            return float(2.0 * res.cost)
        return float(np.sum(p.residuals(u) ** 2))


def curvature_variance(problem: Problem, jac: np.ndarray, index: int) -> float:
    """``[(J'J)^-1]_ii`` in natural units (``jac``: d residuals / d scaled parameters at the optimum)."""
    jn = jac / (problem.hi - problem.lo)[None, :]
    return float(np.linalg.pinv(jn.T @ jn)[index, index])


def profile_interval(problem: Problem, u_hat: np.ndarray, jac: np.ndarray, index: int, se: float, q: float,
                     bounds: tuple[float, float]) -> list[float] | None:
    """The calibrated profile interval (module doc) of parameter ``index``; ``None`` without a finite, positive
    ``se`` or curvature."""
    c = curvature_variance(problem, jac, index)
    if not (math.isfinite(se) and se > 0 and math.isfinite(c) and c > 0):
        return None
    prof = Profile(problem, u_hat, index)
    value = float(problem.natural(np.asarray(u_hat, dtype=float))[index])
    level = q * q

    def excess(theta: float) -> float:
        return (prof.objective(theta) - prof.s_min) * c / (se * se) - level

    return [_end(excess, value, -q * se, bounds[0]), _end(excess, value, q * se, bounds[1])]


def _end(excess: Callable[[float], float], value: float, step: float, bound: float) -> float:
    """Where ``excess`` crosses 0 going from ``value`` by steps ``step`` (doubling) towards ``bound``."""
    inside, sign = value, math.copysign(1.0, step)
    for k in range(5):
        trial = value + step * 2.0 ** k
        past = (trial - bound) * sign >= 0
        if past:                                  # the bound itself: inside or not?
            trial = bound
        if excess(trial) > 0:
            return float(brentq(excess, inside, trial, xtol=END_TOL * abs(step) / 2.0, maxiter=20))
        if past:
            return float(bound)
        inside = trial
    return float(inside)         # still inside after 16 standard errors: the objective is flat (reported as is)


def profile_intervals(problem: Problem, u_hat: np.ndarray, jac: np.ndarray, se: Sequence[float], q: float,
                      bounds: Sequence[tuple[float, float]]) -> list[list[float] | None]:
    """:func:`profile_interval` of every parameter of ``problem``."""
    return [profile_interval(problem, u_hat, jac, i, se[i], q, bounds[i]) for i in range(problem.n)]


def forward_jacobian(problem: Problem, u: np.ndarray) -> np.ndarray:
    """d residuals / d scaled parameters at ``u`` by forward differences (steps of ``DIFF_STEP``, inward at a
    bound), as the fit's own solver takes them."""
    u = np.asarray(u, dtype=float)
    r0 = problem.residuals(u)
    cols = []
    for i in range(problem.n):
        h = DIFF_STEP if u[i] + DIFF_STEP <= 1.0 else -DIFF_STEP
        w = u.copy()
        w[i] += h
        cols.append((problem.residuals(w) - r0) / h)
    return np.stack(cols, axis=1)


def fitted_profile_intervals(problem: Problem, vector: Sequence[float], se: Sequence[float], q: float,
                             bounds: Sequence[tuple[float, float]], only: int | None = None) -> list[list[float] | None]:
    """Profile intervals of a finished fit of ``problem`` whose shared free values are ``vector`` (natural units):
    its Jacobian is taken again at the optimum. ``only``: the first ``only`` parameters (the others ``None``)."""
    u_hat = problem.scaled(vector)
    jac = forward_jacobian(problem, u_hat)
    n = problem.n if only is None else only
    return [profile_interval(problem, u_hat, jac, i, se[i], q, bounds[i]) if i < n else None
            for i in range(problem.n)]
