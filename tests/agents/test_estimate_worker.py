"""agents.estimate_worker: an estimator run behind the decision gives each decision an estimate the estimator
itself produced, of its own period when the worker keeps up and of an earlier one when it does not, the same on
every run; its work is counted from what the bank did; a bad capacity is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings
from agents.estimate_worker import EstimateWorker, WorkPrices

PERIODS = 16


def run(drive, capacity_us: float | None, periods: int = PERIODS, **options) -> tuple[object, list[np.ndarray]]:
    """A tracker (refits at once: the costly form), bare or behind a worker of ``capacity_us``, beside the nominal
    drive; its estimates."""
    estimator = GaussNewtonTracker(TrackerSettings(start=4, every=3))
    if capacity_us is not None:
        estimator = EstimateWorker(estimator, capacity_us, **options)
    return estimator, drive(estimator, periods)


def test_a_worker_gives_the_estimators_own_estimates_late_when_it_cannot_keep_up(nominal_drive):
    _, bare = run(nominal_drive, None)
    fast, fast_estimates = run(nominal_drive, 1e9)
    assert fast.lags == [0] * (PERIODS + 1)
    assert all(np.array_equal(a, b) for a, b in zip(fast_estimates, bare))
    slow, slow_estimates = run(nominal_drive, 2000.0)   # 2 ms of CPU a period: less than refits at once need
    assert max(slow.lags) > 0 and slow.lags[0] == 0
    for k, (estimate, lag) in enumerate(zip(slow_estimates, slow.lags)):
        np.testing.assert_array_equal(estimate, bare[k - lag])   # the estimator's own, of period k - lag
    assert all(b <= a + 1 for a, b in zip(slow.lags, slow.lags[1:]))   # the estimate ages by a period at most
    again, _ = run(nominal_drive, 2000.0)
    assert again.lags == slow.lags


def test_the_work_is_counted_from_what_the_bank_did(nominal_drive):
    tracker, _ = run(nominal_drive, None)
    periods, evaluations, starts, bare_starts = tracker.bank.work_counts()
    assert periods >= 16 * PERIODS and evaluations >= 4 * periods   # (an RK4 period: 4 evaluations at least)
    # the tracker's replays: its perturbations started bare, its centres with their reference (beside the bank's own
    # starts at reset)
    assert 1 <= bare_starts < tracker.counts["replays"] <= starts + bare_starts
    assert WorkPrices().cost_us(1, 0, 0, 0) > 0 and WorkPrices().cost_us(0, 0, 1, 0) > WorkPrices().cost_us(0, 0, 0, 1)


def test_a_worker_behind_sheds_the_trackers_trajectories_and_starts_it_again_once_idle(nominal_drive):
    keeping, _ = run(nominal_drive, 2000.0, 24)
    shedding, _ = run(nominal_drive, 2000.0, 24, shed_after=1)
    tracker = shedding.deviation_bank
    assert keeping.deviation_bank.sheds == keeping.sheds == 0 and tracker.sheds >= 1 and shedding.sheds >= 1
    assert max(shedding.lags) < max(keeping.lags)
    assert tracker.counts["refits"] < keeping.deviation_bank.counts["refits"]
    assert tracker.centre is not None or tracker.paused   # (started again, unless still behind at the end)


@pytest.mark.parametrize("capacity", [0.0, -1.0, float("nan")])
def test_a_bad_capacity_is_refused_naming_it(capacity):
    with pytest.raises(ValueError, match="capacity_us"):
        EstimateWorker(GaussNewtonTracker(), capacity)


@pytest.mark.parametrize("shed_after", [-1, 1.5, True])
def test_a_bad_shedding_threshold_is_refused_naming_it(shed_after):
    with pytest.raises(ValueError, match="shed_after"):
        EstimateWorker(GaussNewtonTracker(), 3500.0, shed_after=shed_after)
