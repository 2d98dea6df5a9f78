"""A Laplace proposal for the bank of hypotheses (:class:`agents.estimator.SpecimenBank`): a least-squares fit of
the unknowns to every measurement so far, and the Gaussian around it.

**Why.** The bank's random-walk moves explore 14 unknowns with 32 hypotheses; within an episode they find the tip
friction but barely move the contact friction and the mass centre from the prior (``docs/notes/mpc-tuning-rounds.md``), and
those two are what the planner's case-C reference depends on. Yet the measurements determine them: given the
specimen the block's motion is deterministic, and a Levenberg-Marquardt fit of the simulated contact-point
displacements to the measured ones (``scipy.optimize.least_squares``, residuals in units of the noise, so its cost is
the negative log-likelihood) reaches the noise level within ten periods after the start. The fit's Jacobian gives
the curvature of the log-likelihood at its minimum (Gauss-Newton: ``J^T J``), and the prior adds its own (a uniform
over each range, taken as a Gaussian of the same variance, so that an unknown the data do not determine stays as
wide as the prior). The bank then becomes an importance sample of the posterior from that Gaussian
(:meth:`agents.estimator.SpecimenBank.refine`): each hypothesis weighed by its likelihood over the proposal's
density, so its weighted spread stays a posterior's and the resample-move steps go on from there.

Everything here works in unit coordinates: each free unknown mapped to ``[0, 1]`` over its prior range.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import least_squares

UNIFORM_PRECISION = 12.0  # 1 / variance of a uniform over [0, 1]


@dataclass
class LaplaceFit:
    """The least-squares fit in unit coordinates: its minimum ``z``, cost (the negative log-likelihood there) and
    the lower Cholesky factor ``root`` of the Gaussian approximation's precision (``root @ root.T``; the precision
    rather than the covariance, whose inverse is ill-conditioned where a residual jumps)."""

    z: np.ndarray
    cost: float
    root: np.ndarray
    evaluations: int

    def draw(self, rng: np.random.Generator, n: int, inflation: float) -> np.ndarray:
        """``n`` draws from the Gaussian with the covariance widened by ``inflation`` (a heavier proposal than
        the posterior it approximates keeps the importance weights bounded)."""
        e = rng.standard_normal((len(self.z), n))
        return self.z + inflation * solve_triangular(self.root.T, e, lower=False).T

    def draw_inside(self, rng: np.random.Generator, n: int, inflation: float, batches: int = 20) -> np.ndarray:
        """Up to ``n`` draws within the unit box (the prior is zero outside it): the Gaussian truncated to the box,
        whose density differs from :meth:`log_density` inside it by a constant only (the importance weights are
        normalised)."""
        kept = [z for _ in range(batches) for z in self.draw(rng, 16 * n, inflation) if np.all((z >= 0) & (z <= 1))]
        return np.array(kept[:n]).reshape(-1, len(self.z))

    def log_density(self, z: np.ndarray, inflation: float) -> np.ndarray:
        """The log density of that widened Gaussian at the rows of ``z``, up to a constant."""
        u = self.root.T @ (np.atleast_2d(z) - self.z).T / inflation
        return -0.5 * np.sum(u * u, axis=0)


def laplace_fit(residuals: Callable[[np.ndarray], np.ndarray], z0: np.ndarray, max_evaluations: int,
                diff_step: float = 1e-3) -> LaplaceFit | None:
    """Fit ``residuals`` (in units of the noise) from ``z0`` within the unit box, and the Gaussian approximation of
    the posterior there: precision ``J^T J`` plus the uniform prior's. None if the fit or its curvature is not
    finite."""
    fit = least_squares(residuals, np.clip(z0, 0.0, 1.0), bounds=(0.0, 1.0), diff_step=diff_step,
                        max_nfev=max_evaluations)
    precision = fit.jac.T @ fit.jac + UNIFORM_PRECISION * np.eye(len(z0))
    if not (np.isfinite(fit.cost) and np.all(np.isfinite(precision))):
        return None
    try:
        root = np.linalg.cholesky(precision)
    except np.linalg.LinAlgError:
        return None
    return LaplaceFit(fit.x, float(fit.cost), root, int(fit.nfev))
