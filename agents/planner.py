"""Receding-horizon optimisation of the bench's action sequence by the cross-entropy method (CEM) over candidate
sequences scored in one batch by :func:`envs.prediction.rollout_costs` (the env's compiled step).

Why CEM: the cost is not differentiable (stick/slip switches, events, the failure penalty) and a batch of
rollouts is what the compiled step does cheaply; CEM needs only costs and keeps the best candidate found. A plan is
piecewise constant over blocks of ``block`` periods (a 20 Hz stage cannot follow more), so a 20-period horizon has
``2 * horizon / block`` free numbers. Each decision warm-starts from the previous plan shifted by one period, and
the warm start and the previous elite are always among the candidates, so a replan never returns a plan that the
model scores worse than the one it had.

With several weighted states (the estimator's hypotheses of :mod:`agents.mpc`) a candidate's cost is the weighted
mean of its costs from each: the plan is good on average over what the specimen may be.

Work budgets (both off by default): ``fev_budget`` ends a candidate's rollout once its kernel evaluations exceed it
(:mod:`envs.prediction`, "Work budget"), and ``decision_fev_budget`` starts no further iteration once the decision's
evaluations exceed it (the first always runs), keeping the best plan found: a decision's cost is then bounded by the
budget plus one iteration, counted in evaluations so that a plan is the same on every machine.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from envs.prediction import BenchState, predict

_SETTINGS = ("horizon", "block", "samples", "iterations", "elites", "sigma0", "seed", "pace_s", "normal_margin",
             "plane_margin_m", "fev_budget", "decision_fev_budget", "change_cost")


@dataclass
class CEMPlanner:
    """Cross-entropy planner (module docstring). ``samples`` candidates per iteration, ``iterations`` per decision,
    the ``elites`` best refit the sampling mean and spread (``sigma0`` at the start of each decision, in action
    units); candidates stay within ``low``-``high`` (per action: a safety envelope); ``normal_margin`` is
    :func:`envs.prediction.predict`'s safety margin (zero: none); ``change_cost`` (cost units per squared action
    unit, zero: none) adds that times the sum of the squared changes between the plan's blocks, the first from the
    last action sent: a tie-breaker, so that where the model's cost is flat the search settles on the same, steady
    plan each time instead of a random one (a teacher whose labels a student can learn)."""

    horizon: int = 20
    block: int = 4
    samples: int = 32
    iterations: int = 3
    elites: int = 6
    sigma0: float = 0.3
    seed: int = 0
    pace_s: float = 0.5
    normal_margin: float = 0.0
    plane_margin_m: float = 0.0
    fev_budget: float = 0.0     # a candidate's work budget (envs.prediction, "Work budget"; zero: none)
    decision_fev_budget: float = 0.0   # a decision's: no further iteration once spent (zero: none)
    change_cost: float = 0.0
    low: tuple[float, float] = (-1.0, -1.0)
    high: tuple[float, float] = (1.0, 1.0)
    _mean: np.ndarray | None = None
    _rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))
    last_cost: float = float("nan")
    last_fevs: float = 0.0      # the kernel's right-hand-side evaluations of the last decision
    evaluations: int = 0

    @classmethod
    def with_settings_of(cls, owner: Any) -> CEMPlanner:
        """A planner whose settings (``horizon`` ... ``change_cost``) are read from the attributes of the same names
        on ``owner`` (a controller that exposes them as its own fields, with its own defaults; one it lacks keeps the
        planner's default, as ``change_cost`` for ``mpc``), converted to the planner's types; ``low``/``high`` are
        the owner's to set (``mpc`` sets its envelope)."""
        settings = {f.name: type(f.default)(getattr(owner, f.name)) for f in fields(cls)
                    if f.name in _SETTINGS and hasattr(owner, f.name)}
        return cls(**settings)

    def __post_init__(self) -> None:
        for name in ("horizon", "block", "samples", "iterations", "elites"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be a positive integer, got {getattr(self, name)!r}")
        for name in ("fev_budget", "decision_fev_budget", "change_cost"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0 (0: none), got {getattr(self, name)!r}")
        if self.elites > self.samples:
            raise ValueError(f"elites ({self.elites}) must not exceed samples ({self.samples})")
        self.reset()

    @property
    def knots(self) -> int:
        return -(-self.horizon // self.block)

    def reset(self) -> None:
        self._mean = None
        self._rng = np.random.default_rng(self.seed)
        self.evaluations = 0

    def _expand(self, knots: np.ndarray) -> np.ndarray:
        """(n, knots, 2) -> (n, horizon, 2) piecewise constant."""
        return np.repeat(knots, self.block, axis=1)[:, :self.horizon]

    def plan(self, states: Sequence[BenchState], weights: Sequence[float], hold: np.ndarray) -> np.ndarray:
        """The best (horizon x 2) plan found from ``states`` (weighted by ``weights``); ``hold`` (the last action)
        starts the very first plan."""
        hold = np.asarray(hold, dtype=float)
        w = np.asarray(weights, dtype=float)
        w = w / w.sum()
        if self._mean is None:
            mean = np.repeat(np.clip(hold, self.low, self.high)[None, :], self.knots, axis=0)
        else:
            mean = self._mean
        sigma = np.full_like(mean, self.sigma0)
        best_knots, best_cost = mean.copy(), np.inf
        work, spent = np.empty(self.samples), 0.0
        for _ in range(self.iterations):
            if 0.0 < self.decision_fev_budget <= spent:
                break   # (the first iteration always runs: the warm start and the previous elite are in it)
            noise = self._rng.standard_normal((self.samples, self.knots, 2))
            cand = np.clip(mean[None] + sigma[None] * noise, self.low, self.high)
            cand[0] = mean
            if np.isfinite(best_cost):
                cand[1] = best_knots
            costs = np.zeros(self.samples)
            plans = self._expand(cand)
            for state, weight in zip(states, w):
                if weight > 0:
                    costs += weight * predict(state, plans, self.pace_s, self.normal_margin,
                                               self.plane_margin_m, self.fev_budget, work)[0]
                    spent += float(work.sum())
            self.evaluations += self.samples * len(states)
            if self.change_cost > 0.0:
                costs += self.change_cost * change_sums(cand, hold)
            order = np.argsort(costs, kind="stable")
            if costs[order[0]] < best_cost:
                best_cost, best_knots = float(costs[order[0]]), cand[order[0]].copy()
            elite = cand[order[:self.elites]]
            mean, sigma = elite.mean(axis=0), np.maximum(elite.std(axis=0), 0.02)
        self.last_cost, self.last_fevs = best_cost, spent
        return self._expand(best_knots[None])[0]

    def advance(self, plan: np.ndarray) -> None:
        """Keep ``plan`` shifted by one period (its last action held) as the next decision's warm start."""
        rest = plan[1:self.horizon + 1]   # (a plan longer than the horizon: mpc's delayed plans, its first part)
        shifted = np.concatenate([rest, np.repeat(plan[-1:], self.horizon - len(rest), axis=0)])
        # back to knots: the value at each block's first period
        self._mean = shifted[::self.block][:self.knots].copy()


def change_sums(knots: np.ndarray, hold: np.ndarray) -> np.ndarray:
    """(n,): each candidate's sum of squared changes between consecutive knots of (n, knots, 2), the first knot's
    from ``hold`` (the last action sent)."""
    steps = np.diff(np.concatenate([np.broadcast_to(hold, (len(knots), 1, 2)), knots], axis=1), axis=1)
    return (steps ** 2).sum(axis=(1, 2))
