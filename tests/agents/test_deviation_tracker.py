"""The Gauss-Newton tracker (agents.deviation_tracker): its residuals carried forward are a replay's, its steps only
lower the fit's cost, its estimate is its centre's deviation, and bad settings are refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from envs.core import reference_deviation
from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings


def test_the_tracker_carries_a_replay_forward_and_only_lowers_the_cost(nominal_drive):
    tracker = GaussNewtonTracker(TrackerSettings(start=4, every=3, chord=2, rebuild=2))
    estimates = nominal_drive(tracker, 16)
    assert tracker.counts["refits"] >= 3 and tracker.counts["accepted"] >= 1
    assert all(after < before for before, after in tracker.costs)
    centre = tracker.centre
    replayed = tracker._replay(centre.theta)   # from its start through the same 16 periods
    np.testing.assert_array_equal(np.concatenate(replayed.rows), np.concatenate(centre.rows))
    np.testing.assert_array_equal(estimates[-1],
                                  reference_deviation(centre.obs, centre.state.ref, tracker.bank.travel_m))


def test_a_spread_refit_keeps_to_its_budget_and_its_trajectories_are_replays(nominal_drive):
    # With a budget the refits run after the command, a part each period: no period's share exceeds the budget, and
    # what they leave running is what a replay from the start gives (every trajectory one row per period measured).
    tracker = GaussNewtonTracker(TrackerSettings(start=4, every=3, chord=2, rebuild=2, budget=200))
    nominal_drive(tracker, 24)
    assert tracker.counts["refits"] >= 1 and tracker.counts["replays"] >= 15
    assert 0 < max(tracker.units) <= 200
    live = tracker._live()
    assert {len(t.rows) for t in live} == {len(tracker.bank.history)}
    for t in (tracker.centre, tracker.base[-1]):
        np.testing.assert_array_equal(np.concatenate(tracker._replay(t.theta).rows), np.concatenate(t.rows))


@pytest.mark.parametrize("field, value", [("start", 0), ("every", 1.5), ("chord", True), ("step", 0.0),
                                          ("damping", -1.0), ("budget", -1)])
def test_bad_settings_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field if field in ("start", "every", "chord", "budget") else "step"):
        TrackerSettings(**{field: value})


def test_the_unit_benchmark_measures_a_start_against_a_step(capsys):
    import json
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_tracker_units import main as bench_main
    assert bench_main(["--benches", "1", "--starts", "2"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["benches"]
    assert row["steps"] > 0 and row["start_ms"] > row["step_ms"] > 0   # (timing: no threshold asserted)
