"""Estimating the unknown specimen and the block's state from the bench's observations: a bank of hypotheses
(a multiple-model Bayesian filter, i.e. a particle filter without resampling).

**Why this estimator.** Given the specimen, the block's motion is deterministic: the bench's only randomness is
the rangefinder noise (Gaussian, ``sensor_noise_m``), and the controller knows every command it sent. So each
hypothesis (a specimen drawn from the prior: tip friction, the three contact friction angles, the mass centre) is
simulated forward with the env's own compiled step (:func:`agents.rollout.step_state`) from its own start, and its
weight is the exact likelihood of the measured contact-point displacements under it. This handles what a UKF or an
EKF would linearise badly (stick/slip switches and events make the state map non-smooth) and needs no process
noise model; moving-horizon estimation would need the same rollouts per iteration of an optimiser, which does not
fit a 5 ms period. Each hypothesis carries the block's full state and its own case-C reference, so the planner
(:mod:`agents.mpc`) predicts from the likely hypotheses directly. The price: the bank is finite, so an estimate is
only as fine as its spacing (the intervals include it), and what the bank does not vary (mass, plane tilts) is
covered by a model-error term ``model_error_m`` added to the sensor noise.

**Divergence.** If every hypothesis is ruled out (each ended the test while the bench runs on, or its state is not
finite), or the weighted covariance is not finite and positive definite, the weights go back to the prior
(uniform) and :attr:`SpecimenBank.fallbacks` counts it; the controller reports it in its ``info``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from envs.core import N_INFO, OBS_DIM, OBS_POS, StartError, new_workspace
from envs.triplanar_shear_v1 import (
    B_RANGE,
    RANDOM_FRICTION_DEG,
    RANDOM_MASS_CENTRE_M,
    RANDOM_TIP_FRICTION_DEG,
    Bench,
    TriPlanarShearV1Env,
)
from triplanar.outcome import RUNNING
from triplanar.specimen import Foundation, Specimen

from .rollout import BenchState, snapshot, step_state

PARAMETERS = ("tip_friction_deg", "friction1_deg", "friction2_deg", "friction3_deg", "mass_centre1_m",
              "mass_centre2_m", "mass_centre3_m")


def latin_hypercube(rng: np.random.Generator, n: int, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``n`` points, one in each of ``n`` equal strata of every coordinate (the bank covers each range evenly)."""
    d = len(low)
    u = (np.argsort(rng.random((n, d)), axis=0) + rng.random((n, d))) / n
    return low + u * (high - low)


def parameters_of(specimen: Specimen) -> np.ndarray:
    return np.concatenate([[specimen.tip_friction_deg], np.asarray(specimen.friction_deg, dtype=float),
                           np.asarray(specimen.mass_centre_m, dtype=float)])


def with_parameters(specimen: Specimen, theta: np.ndarray) -> Specimen:
    return replace(specimen, tip_friction_deg=float(theta[0]), friction_deg=tuple(float(v) for v in theta[1:4]),
                   mass_centre_m=np.array(theta[4:7], dtype=float))


def prior_ranges(prior: Specimen, intervals: dict[str, tuple[float, float]] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """v1's ranges of the unknown specimen (``docs/environment.md``) around ``prior``'s contact friction and mass
    centre, the tip friction over v1's whole range; a parameter with an identified interval (``intervals``, e.g.
    :func:`triplanar.prior.fitted_intervals` of a fit) is drawn within that interval instead."""
    centre = parameters_of(prior)
    half = np.array([0.0] + [RANDOM_FRICTION_DEG] * 3 + [RANDOM_MASS_CENTRE_M] * 3)
    low, high = centre - half, centre + half
    low[0], high[0] = RANDOM_TIP_FRICTION_DEG
    for name, (lo, hi) in (intervals or {}).items():
        k = PARAMETERS.index(name)
        low[k], high[k] = lo, hi
    return low, high


@dataclass
class SpecimenBank:
    """The bank of hypotheses (module docstring) for one episode."""

    prior: Specimen
    foundation: Foundation
    env_kwargs: dict
    size: int = 32
    seed: int = 0
    sensor_noise_m: float = 2e-4
    model_error_m: float = 3e-4
    intervals: dict | None = None

    def reset(self, load_N: float) -> None:
        env = TriPlanarShearV1Env(**self.env_kwargs)
        low, high = prior_ranges(self.prior, self.intervals)
        self.resolution = (high - low) / self.size
        draws = latin_hypercube(np.random.default_rng([self.seed, round(load_N * 1000)]), self.size, low, high)
        self.theta, self.states = [], []
        for theta in draws:
            try:
                env.reset(seed=0, options={"bench": Bench(with_parameters(self.prior, theta), self.foundation,
                                                          float(load_N))})
            except StartError:  # friction would hold this hypothesis at rest: the bench's block did start
                continue
            self.theta.append(theta)
            self.states.append(snapshot(env))
        if not self.states:
            raise StartError(f"no hypothesis of the prior starts at {load_N:g} N")
        self.theta = np.array(self.theta)
        self.log_w = np.zeros(len(self.states))
        self.alive = np.ones(len(self.states), dtype=bool)
        self.fallbacks = 0
        self.diverged = False
        self._applied, self._obs, self._inf = np.zeros(2), np.zeros(OBS_DIM), np.zeros(N_INFO)
        self._ws = new_workspace()

    def update(self, action: np.ndarray, obs: np.ndarray) -> None:
        """Advance every hypothesis by the period the bench just ran with ``action`` and weigh it by ``obs``."""
        raw = np.asarray(action, dtype=np.float64)
        measured = np.asarray(obs[B_RANGE:B_RANGE + 9], dtype=float)
        var = self.sensor_noise_m ** 2 + self.model_error_m ** 2
        for i, s in enumerate(self.states):
            if not self.alive[i]:
                continue
            code = step_state(s.y, s.p, s.modes, s.armed, s.st, s.ref, s.cfg, s.bc, s.bs, s.queue, raw,
                              self._applied, self._obs, self._inf, self._ws)
            r = self._obs[OBS_POS:OBS_POS + 9] - measured
            ll = -0.5 * float(r @ r) / var
            if code != RUNNING or not math.isfinite(ll) or not np.all(np.isfinite(s.y)):
                self.alive[i] = False
                self.log_w[i] = -math.inf
            else:
                self.log_w[i] += ll
        self.diverged = False
        if not self.alive.any() or not self._healthy():
            self.fallbacks += 1
            self.diverged = True
            self.alive[:] = np.array([np.all(np.isfinite(s.y)) for s in self.states])
            self.log_w[:] = np.where(self.alive, 0.0, -math.inf)

    def weights(self) -> np.ndarray:
        if not self.alive.any():
            return np.full(len(self.states), 1.0 / len(self.states))
        w = np.exp(self.log_w - np.max(self.log_w[self.alive]))
        w[~self.alive] = 0.0
        return w / w.sum()

    def _healthy(self) -> bool:
        mean, cov = self.mean_cov()
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            return False
        return bool(np.all(np.linalg.eigvalsh(cov) > 0.0))

    def mean_cov(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean and covariance of the parameters, the bank's spacing added (it bounds the resolution)."""
        w = self.weights()
        mean = w @ self.theta
        d = self.theta - mean
        return mean, (d * w[:, None]).T @ d + np.diag(self.resolution ** 2)

    def interval(self, k: int = 0, z: float = 1.96) -> tuple[float, float]:
        """The 95 % interval of parameter ``k`` (Gaussian from :meth:`mean_cov`)."""
        mean, cov = self.mean_cov()
        half = z * math.sqrt(cov[k, k])
        return float(mean[k] - half), float(mean[k] + half)

    def best(self, count: int, min_ess: float = 1.0) -> tuple[list[BenchState], np.ndarray]:
        """Up to ``count`` hypotheses to plan with (copies of their states) and their weights: picked by systematic
        resampling (the likely ones when the weights are peaked, a spread of the prior while they are flat, so
        the first plans are robust to what is not yet known), each weighted by how often it was picked. The
        weights are tempered (``w ** beta``, the largest ``beta <= 1`` that leaves an effective sample size of at
        least ``min_ess``): the bank is finite and the bench is not one of its hypotheses (tilts, mass), so a
        planner that trusted a single hypothesis would plan for a specimen that is not there."""
        w = self._tempered(min_ess)
        picks = np.searchsorted(np.cumsum(w), (np.arange(count) + 0.5) / count)
        picks = np.minimum(picks, len(w) - 1)
        chosen, counts = np.unique(picks, return_counts=True)
        return [self.states[i].copy() for i in chosen], counts / counts.sum()

    def _tempered(self, min_ess: float) -> np.ndarray:
        w = self.weights()
        if min_ess <= 1.0 or 1.0 / float(w @ w) >= min_ess or self.alive.sum() <= 1:
            return w
        lw = np.where(self.alive, self.log_w - np.max(self.log_w[self.alive]), 0.0)

        def tempered(beta: float) -> np.ndarray:
            t = np.where(self.alive, np.exp(beta * lw), 0.0)  # the ruled-out stay out at any beta
            return t / t.sum()
        low, high = 0.0, 1.0
        for _ in range(30):  # bisection on beta: the effective sample size falls as beta grows
            beta = 0.5 * (low + high)
            t = tempered(beta)
            low, high = (beta, high) if 1.0 / float(t @ t) >= min_ess else (low, beta)
        return tempered(low)
