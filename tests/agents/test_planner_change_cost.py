"""The planner's tie-breaking cost on changes of action (``change_cost``, ``agents.planner``): none by default
(``limit``'s actions bitwise as before the setting), and a positive one steadies the plan."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from agents.limit import LimitController
from agents.mpc import MPCController
from agents.planner import CEMPlanner, change_sums


SMALL = {"horizon": 8, "samples": 8, "iterations": 2}
# limit (SMALL) on the nominal 40 N bench, 6 decisions, before change_cost existed (commit ee5b8f5)
BEFORE = "f17f4d948f7edf52"


def test_change_sums_are_the_squared_steps_from_the_last_action():
    knots = np.array([[[0.1, 0.0], [0.3, 0.0], [0.3, -0.2]]])
    assert change_sums(knots, np.array([0.0, 0.1]))[0] == pytest.approx(0.1 ** 2 + 0.1 ** 2 + 0.2 ** 2 + 0.2 ** 2)
    assert change_sums(np.zeros((2, 4, 2)), np.zeros(2)).tolist() == [0.0, 0.0]


def test_no_change_cost_leaves_limits_actions_bitwise_as_they_were(limit_actions):
    assert hashlib.sha256(limit_actions(**SMALL).tobytes()).hexdigest()[:16] == BEFORE


def test_a_change_cost_changes_the_plan_and_steadies_it(limit_actions):
    plain, steady = limit_actions(**SMALL), limit_actions(**SMALL, change_cost=0.05)
    assert not np.array_equal(plain, steady)
    def moved(a: np.ndarray) -> float:
        return float(np.abs(np.diff(a, axis=0)).sum())
    assert moved(steady) < moved(plain)


def test_change_cost_is_read_where_the_owner_has_it_and_refused_below_zero():
    assert CEMPlanner.with_settings_of(LimitController(change_cost=0.02)).change_cost == 0.02
    assert CEMPlanner.with_settings_of(MPCController()).change_cost == 0.0   # mpc has no such setting
    with pytest.raises(ValueError, match="change_cost must be >= 0"):
        CEMPlanner(change_cost=-1.0)
