"""The planners' work budgets (envs/prediction.py "Work budget", agents/planner.py): counted in the kernel's
evaluations, off by default (predictions bitwise as before), and when on, a candidate's rollout or a decision's
iterations end where the budget is spent."""

from __future__ import annotations

import numpy as np

from agents.heldout import nominal_benches
from agents.planner import CEMPlanner
from envs.prediction import predict, snapshot
from envs.triplanar_shear_v1 import BS_PREV, TriPlanarShearV1Env


def _state():
    env = TriPlanarShearV1Env()
    env.reset(seed=0, options={"bench": nominal_benches([40.0])[0]})
    return snapshot(env)


def _plans():
    plans = np.random.default_rng(3).uniform(-0.5, 0.5, (6, 20, 2))
    plans[1] = np.array([0.0, 0.1])   # a gentle plan that travels
    return plans


def test_without_a_budget_the_prediction_is_unchanged_and_its_work_counted():
    state, plans = _state(), _plans()
    work = np.zeros(len(plans))
    costs, dists, codes = predict(state, plans, 0.3, 0.1)
    again = predict(state, plans, 0.3, 0.1, work=work)
    for a, b in zip((costs, dists, codes), again):
        assert np.array_equal(a, b, equal_nan=True)
    assert np.all(work >= 20)   # at least one evaluation per period of each candidate's rollout


def test_a_candidate_ends_in_the_period_its_budget_is_spent():
    """A budget of one evaluation: every candidate's rollout ends after its first period, and is scored there (a
    finite cost, not the failure penalty: the distance then times the travel still to go)."""
    state, plans = _state(), _plans()
    work = np.zeros(len(plans))
    full_work = np.zeros(len(plans))
    full, _, _ = predict(state, plans, 0.3, 0.1, work=full_work)
    costs, dists, codes = predict(state, plans, 0.3, 0.1, fev_budget=1.0, work=work)
    assert np.all(np.isfinite(dists[:, 0])) and np.all(np.isnan(dists[:, 1:]))
    assert np.all(codes[:, 1:] == -1)
    assert np.all(work < full_work) and np.all(np.isfinite(costs))
    assert not np.array_equal(costs, full)


def test_a_decision_starts_no_iteration_once_its_budget_is_spent():
    state = _state()
    hold = state.bs[BS_PREV:BS_PREV + 2]
    free = CEMPlanner(horizon=8, samples=8, iterations=3, elites=2)
    free.plan([state, state], [0.5, 0.5], hold)
    capped = CEMPlanner(horizon=8, samples=8, iterations=3, elites=2, decision_fev_budget=1.0)
    capped.plan([state, state], [0.5, 0.5], hold)
    assert free.evaluations == 3 * 8 * 2 and capped.evaluations == 8 * 2   # the first iteration only
    assert 0 < capped.last_fevs < free.last_fevs


def test_a_negative_budget_is_refused_naming_it():
    import pytest
    for name in ("fev_budget", "decision_fev_budget"):
        with pytest.raises(ValueError, match=name):
            CEMPlanner(**{name: -1.0})
