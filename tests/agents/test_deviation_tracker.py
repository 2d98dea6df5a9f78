"""The Gauss-Newton tracker (agents.deviation_tracker): its residuals carried forward are a replay's, its steps only
lower the fit's cost, its estimate is its centre's deviation, and bad settings are refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from agents.mpc import nominal_command
from envs.core import reference_deviation
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings
from experiments.train_student import judge_draws


def test_the_tracker_carries_a_replay_forward_and_only_lowers_the_cost():
    (_, bench), = judge_draws(1, {})
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    tracker = GaussNewtonTracker(TrackerSettings(start=4, every=3, chord=2, rebuild=2))
    tracker.reset(bench.load_N, env.unwrapped.config)
    action = nominal_command(env.unwrapped.config).astype(np.float32)
    estimates = []
    for _ in range(16):
        estimates.append(tracker.estimate(obs))
        tracker.advance(action)
        obs, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
    estimates.append(tracker.estimate(obs))
    assert tracker.counts["refits"] >= 3 and tracker.counts["accepted"] >= 1
    assert all(after < before for before, after in tracker.costs)
    centre = tracker.centre
    replayed = tracker._replay(centre.theta)   # from its start through the same 16 periods
    np.testing.assert_array_equal(np.concatenate(replayed.rows), np.concatenate(centre.rows))
    np.testing.assert_array_equal(estimates[-1],
                                  reference_deviation(centre.obs, centre.state.ref, tracker.bank.travel_m))


@pytest.mark.parametrize("field, value", [("start", 0), ("every", 1.5), ("chord", True), ("step", 0.0),
                                          ("damping", -1.0)])
def test_bad_settings_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field if field in ("start", "every", "chord") else "step"):
        TrackerSettings(**{field: value})
