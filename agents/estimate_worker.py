"""An estimator run behind the decision, as its own thread would run it at a bench (finding 14c of
``docs/notes/student-experiments.md``).

A specimen bank's or a tracker's work in a period is not bounded: a hypothesis period costs the kernel ~5
right-hand-side evaluations where the block slides or sticks cleanly and thousands where a contact slips slowly at
the edge of sticking (the env's energy-balance redo, ``docs/environment.md``). Run in the decision's path, such a
stretch delays the command; at a bench the estimator runs on its own instead, and the decision takes the latest
estimate it has finished. :class:`EstimateWorker` models that, deterministically.

**Work, counted.** Each period's work is counted from what the estimator did
(:meth:`agents.estimator.SpecimenBank.work_counts`: hypothesis periods stepped, the kernel's evaluations in them,
fresh starts with and without the case-C reference) and priced in microseconds of this machine's CPU by
:class:`WorkPrices` (``benchmarks/bench_tracker_units.py``), so that a run is the same on every machine and
under any load.

**The worker.** Period k's measurement arrives at ``k * period``. The worker takes the periods in order, each once
the one before is done, at ``capacity_us`` of CPU per period (the slack the decision leaves it): the estimator's
update with the measurement (``estimate``) and then with the command (``advance``, a tracker's refit work included).
A decision finds the worker either idle, and then the update with the new measurement runs in the decision's path
(as without a worker: the decision uses its own period's estimate), or busy, and then uses the latest period's
estimate the worker had finished. In simulation every update runs at once; only when its result becomes visible is
modelled. With ``shed_after`` a worker more than that many periods behind at a decision sheds the optional work of a
tracker (:meth:`agents.deviation_tracker.GaussNewtonTracker.shed`: its trajectories, its estimate the bank's again)
and keeps it paused until it is idle again; a bank's own hypotheses are never shed. ``lags`` records how many
periods old each decision's estimate was (every episode since the worker was made).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .deviation_bank import WrapsDeviationBank


@dataclass(frozen=True)
class WorkPrices:
    """Microseconds of CPU per unit of an estimator's work on this machine: a hypothesis period stepped (its
    overhead) and each kernel evaluation in it (the least-squares line through the 15,494 periods a tracker-driven
    policy's estimator steps on 12 judge episodes: 15.1-17.8 us + 0.84-0.85 us per evaluation, two runs, load 5-8:
    ``benchmarks/bench_tracker_units.py --prices RUN``), a fresh start with its case-C reference and one without
    (1.3-1.8 and 0.7-1.0 ms: ``benchmarks/bench_tracker_units.py``). Loaded figures: a quiet core is faster, so a
    worker priced so is slower than it would be."""

    period_us: float = 17.8
    evaluation_us: float = 0.85
    start_us: float = 1500.0
    bare_start_us: float = 850.0

    def cost_us(self, periods: float, evaluations: float, starts: float, bare_starts: float) -> float:
        return (periods * self.period_us + evaluations * self.evaluation_us + starts * self.start_us
                + bare_starts * self.bare_start_us)


class EstimateWorker(WrapsDeviationBank):
    """``inner`` (a :class:`agents.deviation_bank.DeviationBank` or a :class:`agents.deviation_tracker
    .GaussNewtonTracker`: ``reset``, ``estimate``, ``advance`` and its ``bank``) run behind the decision with
    ``capacity_us`` of CPU per control period (module docstring)."""

    def __init__(self, inner: Any, capacity_us: float, prices: WorkPrices = WorkPrices(),
                 shed_after: int | None = None):
        if not capacity_us > 0.0:
            raise ValueError(f"EstimateWorker: capacity_us must be a positive number of microseconds, "
                             f"got {capacity_us!r}")
        if shed_after is not None and (isinstance(shed_after, bool) or not isinstance(shed_after, int)
                                       or shed_after < 0):
            raise ValueError(f"EstimateWorker: shed_after must be a non-negative integer (periods), got "
                             f"{shed_after!r}")
        self.deviation_bank, self.capacity_us, self.prices = inner, float(capacity_us), prices
        self.shed_after = shed_after if hasattr(inner, "shed") else None
        self.lags: list[int] = []
        self.sheds = 0   # (every episode's, as lags)

    @property
    def counts(self) -> dict:
        """The wrapped tracker's refit counts ({} for a bank)."""
        return getattr(self.deviation_bank, "counts", {})

    def reset(self, load_N: float, config: Any) -> None:
        self.deviation_bank.reset(load_N, config)
        self.period_us = 1e6 * float(config.dt)
        self.k = 0
        self.busy_until = 0.0    # when the worker finishes what it has been given (us from the first measurement)
        self.pending: list[tuple[float, int, np.ndarray]] = []   # (done at, period, estimate), in period order
        self.current: tuple[int, np.ndarray] | None = None   # the latest visible (period, estimate)
        self._counted = np.array(self.bank.work_counts(), dtype=float)   # (the bank's start-up is not charged)

    def _spent_us(self) -> float:
        """The worker's time for the work done since the last call: its CPU over its share of the period."""
        counts = np.array(self.bank.work_counts(), dtype=float)
        cost = self.prices.cost_us(*(counts - self._counted))
        self._counted = counts
        return cost * self.period_us / self.capacity_us

    def estimate(self, obs: np.ndarray) -> np.ndarray:
        """The estimate the decision of this period has: its own if the worker was idle, else the latest the
        worker had finished."""
        arrival = self.k * self.period_us
        idle = self.busy_until <= arrival
        start = arrival if idle else self.busy_until
        if self.shed_after is not None:
            self._shed_or_resume((start - arrival) / self.period_us)
        estimate = self.deviation_bank.estimate(obs)
        self.busy_until = start + self._spent_us()
        self.pending.append((self.busy_until, self.k, estimate))
        visible = [p for p in self.pending if p[0] <= arrival or (idle and p[1] == self.k)]
        if visible:
            self.current = visible[-1][1:]
            self.pending = [p for p in self.pending if p[1] > self.current[0]]
        if self.current is None:   # (the first measurement finds the worker idle: never)
            raise RuntimeError("EstimateWorker: no estimate finished by the first decision")
        self.lags.append(self.k - self.current[0])
        self.k += 1
        return self.current[1]

    def _shed_or_resume(self, behind: float) -> None:
        """The tracker shed and paused once the worker is more than ``shed_after`` periods ``behind``; resumed once
        the worker is idle."""
        tracker = self.deviation_bank
        if not tracker.paused and behind > self.shed_after:
            tracker.shed()
            tracker.paused = True
            self.sheds += 1
        elif tracker.paused and behind == 0.0:
            tracker.paused = False

    def advance(self, action: np.ndarray) -> None:
        """The estimator advanced by the command sent, on the worker's time."""
        self.deviation_bank.advance(action)
        self.busy_until += self._spent_us()
