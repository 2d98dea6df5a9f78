"""The twin ``limit`` of :mod:`experiments.privileged_bound`: shown the same states as the driving ``limit``, it acts
exactly as the driver when its planner seed is the same (so a difference between the twins is the search's own
randomness), differently with another seed, and the measurement refuses the judge's draws."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import privileged_bound as pb

QUICK = {"horizon": 8, "samples": 8, "iterations": 1, "elites": 2}   # a small search: the bookkeeping is the point


def test_twins_of_one_seed_agree_and_of_two_seeds_differ():
    draw = next(d for d in range(60_000, 60_010) if pb.bench_of_draw(pb.TUNING_SEED, d, {}) is not None)
    ran, twin = pb.twin_actions(draw, (0, 0), **QUICK)
    assert ran.shape == twin.shape and ran.shape[1] == 2 and len(ran) >= 1
    np.testing.assert_array_equal(ran, twin)
    ran2, twin2 = pb.twin_actions(draw, (0, 1), **QUICK)
    np.testing.assert_array_equal(ran2[0], ran[0])            # the driver is the same limit
    assert np.abs(ran2[0] - twin2[0]).max() > 0               # the twin's search drew other samples


def test_the_judge_draws_are_refused():
    with pytest.raises(ValueError, match="--first"):
        pb.label_noise(10, 2)
