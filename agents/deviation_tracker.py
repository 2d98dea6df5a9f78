"""A Gauss-Newton tracker of the specimen beside the real-time bank (finding 14 of
``docs/notes/student-experiments.md``): ``mpc``'s refining bank estimates the deviation from the case-C path as well
as the bench's sensors allow, at 50-60 ms of CPU a period; nearly all of it is the finite-difference Jacobian of its
least-squares fit (:mod:`agents.refine`), recomputed from fresh starts at every refinement. Here the Jacobian is
carried forward instead.

**The tracker.** :class:`GaussNewtonTracker` runs :mod:`agents.deviation_bank`'s plain bank (16 hypotheses, its
estimate until the tracker starts). After ``start`` periods the bank's likeliest hypothesis becomes the *centre*; the
centre and one perturbation per free unknown (``step`` in the unit coordinates of :mod:`agents.refine`, one-sided
into the prior's box) are replayed from their starts through the history and then stepped with the bench every
period, so their residuals against every measurement (in units of the likelihood's noise, as
:meth:`agents.estimator.SpecimenBank._residuals`) and the Jacobian between them accumulate at ``n_free + 1`` steps a
period. Every ``every`` periods up to ``chord`` damped Gauss-Newton steps (Levenberg-Marquardt damping on the
diagonal, adapted: /3 on a success, x10 on a failure) on the kept Jacobian each replay one new centre, kept if its
cost is lower (the first failure ends the refit); every ``rebuild``-th refit replays the perturbations around the
centre. The estimate is the centre's own deviation from its own case-C reference (as the env computes the truth's).

**Not yet real time.** A refit runs at once, in the period it falls on (tens of ms at the 99th percentile; 5-6 ms
a period on average): a bench would spread its replays over the periods' slack. Measured, and the policies driven
with it: :mod:`experiments.gn_tracker`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from envs.core import OBS_POS, reference_deviation

from .deviation_bank import DeviationBank

FAILED_ROW = 30.0   # a residual row, in noise units, of a trajectory that ended the test (the estimator's)


@dataclass
class Trajectory:
    """One hypothesis run with the bench's commands: its state, unknowns, last state observation and residual rows."""

    state: Any
    theta: np.ndarray
    obs: np.ndarray
    rows: list = field(default_factory=list)
    ended: bool = False

    def cost(self) -> float:
        r = np.concatenate(self.rows) if self.rows else np.zeros(0)
        return 0.5 * float(r @ r)


@dataclass(frozen=True)
class TrackerSettings:
    start: int = 6
    every: int = 4
    chord: int = 2
    rebuild: int = 2
    step: float = 1e-3
    damping: float = 1e-2

    def __post_init__(self):
        for name in ("start", "every", "chord", "rebuild"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"TrackerSettings.{name} must be a positive integer, got {value!r}")
        if not 0.0 < self.step < 0.5 or not self.damping > 0.0:
            raise ValueError(f"TrackerSettings: step in (0, 0.5) and damping > 0, got {self.step!r}, "
                             f"{self.damping!r}")


class GaussNewtonTracker:
    """The tracker (module docstring), with :class:`agents.deviation_bank.DeviationBank`'s interface."""

    def __init__(self, settings: TrackerSettings = TrackerSettings(), bank: DeviationBank | None = None):
        self.settings = settings
        self.deviation_bank = bank if bank is not None else DeviationBank.of_size()
        self.cpu = {"step_s": 0.0, "replay_s": 0.0}
        self.counts = {"refits": 0, "accepted": 0, "replays": 0}
        self.costs: list[tuple[float, float]] = []   # (before, after) of every accepted step

    @property
    def bank(self) -> Any:
        return self.deviation_bank.bank

    @property
    def periods(self) -> int:
        return self.deviation_bank.periods

    @property
    def min_ess(self) -> float:
        return self.deviation_bank.min_ess

    def reset(self, load_N: float, config: Any) -> None:
        self.deviation_bank.reset(load_N, config)
        self.centre: Trajectory | None = None
        self.base: list[Trajectory] = []   # the Jacobian's: its centre, then one perturbation per free unknown
        self.signed_steps: list[float] = []
        self.damping = self.settings.damping
        b = self.bank
        self.sigma = math.sqrt(b.sensor_noise_m ** 2 + b.model_error_m ** 2)
        self.free = (b.high > b.low) & ~b.circular
        self.low, self.span = b.low[self.free], (b.high - b.low)[self.free]

    def estimate(self, obs: np.ndarray) -> np.ndarray:
        """The bank weighed by the period just measured; every trajectory's residual row; the tracker started or
        refitted when due; the centre's deviation once it runs (the bank's before)."""
        estimate = self.deviation_bank.estimate(obs)
        history = len(self.bank.history)
        if self.centre is not None and history:
            measured = self.bank.history[-1][1]
            for t in self._live():
                t.rows.append(self._row(t, measured))
        if self.centre is None and history == self.settings.start:
            self._rebuild(self._likeliest())
        elif self.centre is not None and history > self.settings.start and history % self.settings.every == 0:
            self._refit()
        if self.centre is None or self.centre.ended:
            return estimate
        return reference_deviation(self.centre.obs, self.centre.state.ref, self.bank.travel_m)

    def advance(self, action: np.ndarray) -> None:
        self.deviation_bank.advance(action)
        started = time.thread_time()
        raw = np.asarray(action, dtype=np.float64)
        for t in self._live():
            self._step(t, raw)
        self.cpu["step_s"] += time.thread_time() - started

    def _live(self) -> list[Trajectory]:
        if self.centre is None:
            return []
        return self.base + ([self.centre] if self.centre is not self.base[0] else [])

    def _step(self, t: Trajectory, raw: np.ndarray) -> None:
        if not t.ended:
            t.ended, t.obs = self.bank.step_hypothesis(t.state, raw)

    def _row(self, t: Trajectory, measured: np.ndarray) -> np.ndarray:
        if t.ended:
            return np.full(9, FAILED_ROW)
        return (t.obs[OBS_POS:OBS_POS + 9] - measured) / self.sigma

    def _likeliest(self) -> np.ndarray:
        b = self.bank
        alive = np.flatnonzero(b.alive)
        return b.theta[alive[np.argmax(b.ll[alive])]].copy()

    def _theta(self, z: np.ndarray, like: np.ndarray) -> np.ndarray:
        theta = like.copy()
        theta[self.free] = self.low + np.clip(z, 0.0, 1.0) * self.span
        return theta

    def _z(self, theta: np.ndarray) -> np.ndarray:
        return (theta[self.free] - self.low) / self.span

    def _replay(self, theta: np.ndarray) -> Trajectory | None:
        """A trajectory from its start through the history (None if it does not start)."""
        started = time.thread_time()
        state, obs = self.bank.start_hypothesis(theta)
        self.counts["replays"] += 1
        if state is None:
            return None
        t = Trajectory(state, theta, obs)
        for raw, measured in self.bank.history:
            self._step(t, raw)
            t.rows.append(self._row(t, measured))
        self.cpu["replay_s"] += time.thread_time() - started
        return t

    def _rebuild(self, theta: np.ndarray) -> None:
        """The centre at ``theta`` and its perturbations, replayed (the tracker stays as it was if one does not
        start)."""
        z = self._z(theta)
        steps = [self.settings.step if z[j] + self.settings.step <= 1.0 else -self.settings.step
                 for j in range(len(z))]
        thetas = [theta] + [self._theta(z + s * np.eye(len(z))[j], theta) for j, s in enumerate(steps)]
        built = [self._replay(th) for th in thetas]
        if any(t is None for t in built):
            return
        self.base, self.signed_steps, self.centre = built, steps, built[0]

    def _refit(self) -> None:
        self.counts["refits"] += 1
        if self.centre.ended or any(t.ended for t in self.base):
            self._rebuild(self.centre.theta if not self.centre.ended else self.base[0].theta)
            return
        r0 = np.concatenate(self.base[0].rows)
        jac = np.stack([(np.concatenate(t.rows) - r0) / s for t, s in zip(self.base[1:], self.signed_steps)], axis=1)
        normal = jac.T @ jac
        for _ in range(self.settings.chord):
            r = np.concatenate(self.centre.rows)
            damped = normal + self.damping * np.diag(np.diag(normal)) + 1e-9 * np.eye(len(normal))
            z = self._z(self.centre.theta) - np.linalg.solve(damped, jac.T @ r)
            new = self._replay(self._theta(z, self.centre.theta))
            if new is None or new.ended or not new.cost() < self.centre.cost():
                self.damping = min(self.damping * 10.0, 1e4)
                break
            self.costs.append((self.centre.cost(), new.cost()))
            self.centre = new
            self.counts["accepted"] += 1
            self.damping = max(self.damping / 3.0, 1e-4)
        if self.counts["refits"] % self.settings.rebuild == 0:
            self._rebuild(self.centre.theta)


def deviation_estimator(bank_size: int, tracker: bool = False) -> DeviationBank | GaussNewtonTracker:
    """The estimate a bank-driven policy runs on (``banked:RUN``, a bank-trained run's training rows): a
    :class:`agents.deviation_bank.DeviationBank` of ``bank_size`` hypotheses, or that bank's tracker (the module's
    settings)."""
    bank = DeviationBank.of_size(int(bank_size))
    return GaussNewtonTracker(bank=bank) if tracker else bank
