"""``mpc``'s start: the designed excitation it sends while the estimator learns, before the first plan."""

from __future__ import annotations

import numpy as np
import pytest

from agents.mpc import MPCController
from envs.core import make_config


def test_the_start_alternates_thrust_and_tip_offset_every_block():
    config = make_config(None)
    controller = MPCController(bank_size=4, samples=4, elites=2, iterations=1, horizon=4, block=4, start_periods=8,
                               start_thrust=0.1, start_offset_m=-0.002)
    controller.reset(40.0, config)
    obs = np.zeros(15, dtype=np.float32)
    actions = np.array([controller.act(obs) for _ in range(8)], dtype=float)
    thrust = 0.5 * (actions[:, 0] + 1.0) * config.thrust_scale  # in load levels
    offset_m = actions[:, 1] * config.offset_range_m - config.tip_offset_m
    assert thrust == pytest.approx([1.1] * 4 + [0.9] * 4, abs=1e-6)
    assert offset_m == pytest.approx([-0.002] * 4 + [0.002] * 4, abs=1e-8)
    assert not controller.info["planned"]  # still the start: no plan yet


def test_without_excitation_the_start_is_the_nominal_command():
    config = make_config(None)
    controller = MPCController(bank_size=4, samples=4, elites=2, iterations=1, horizon=4, start_periods=3,
                               start_thrust=0.0, start_offset_m=0.0)
    controller.reset(40.0, config)
    obs = np.zeros(15, dtype=np.float32)
    actions = np.array([controller.act(obs) for _ in range(3)], dtype=float)
    nominal = [2.0 / config.thrust_scale - 1.0, config.tip_offset_m / config.offset_range_m]
    assert np.allclose(actions, nominal, atol=1e-7)
