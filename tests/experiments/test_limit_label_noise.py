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


def test_the_span_figures_read_the_twins_difference():
    ran = [np.array([[0.2, 0.0], [0.4, 0.0]]), np.array([[0.0, 0.0], [0.2, 0.0]])]
    twin = [r + np.array([0.0, 0.2]) for r in ran]       # every difference 0.2 on one component
    out = pb.span_figures(list(zip(ran, twin)), resamples=50)
    assert out["episodes"] == 2 and out["n"] == 4
    np.testing.assert_allclose(out["search_noise"], np.sqrt(0.2 ** 2 / 2 / 2))   # mean over 2 components, / 2
    np.testing.assert_allclose(out["search_noise_95"], [out["search_noise"]] * 2)
    np.testing.assert_allclose(out["label_spread"], np.sqrt(0.02 / 2))             # x: 0.2, 0.4, 0, 0.2 about 0.2


def test_the_judged_limit_takes_the_limit_settings(monkeypatch):
    judged = []
    monkeypatch.setattr(pb, "judge_controller", lambda controller, *args: judged.append(controller) or {})
    assert pb.main(["--judge", "3", "--limit", "change_cost=0.01"]) == 0
    assert pb.main(["--judge", "3"]) == 0
    assert [c.change_cost for c in judged] == [0.01, 0.0]
