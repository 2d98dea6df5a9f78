"""``mpc``'s start: the designed excitation it sends while the estimator learns, before the first plan."""

from __future__ import annotations

import numpy as np
import pytest

from agents.mpc import MPCController
from envs.core import make_config
from triplanar import kernel as K


@pytest.mark.parametrize("ratio, centre", [(-1.0, 0.0), (0.0, 0.0), (1.0, 0.0), (-1.0, 0.002)])
def test_the_start_alternates_thrust_and_tip_offset_every_block(ratio, centre):
    """The second block's tip offset is ``start_offset_ratio`` times the first's (mirrored, nominal or held), both
    about ``start_centre_m``."""
    config = make_config(None)
    controller = MPCController(bank_size=4, samples=4, elites=2, iterations=1, horizon=4, block=4, start_periods=8,
                               start_thrust=0.1, start_offset_m=-0.002, start_offset_ratio=ratio,
                               start_centre_m=centre)
    controller.reset(40.0, config)
    obs = np.zeros(15, dtype=np.float32)
    actions = np.array([controller.act(obs) for _ in range(8)], dtype=float)
    thrust = 0.5 * (actions[:, 0] + 1.0) * config.thrust_scale  # in load levels
    offset_m = actions[:, 1] * config.offset_range_m - config.tip_offset_m
    assert thrust == pytest.approx([1.1] * 4 + [0.9] * 4, abs=1e-6)
    assert offset_m == pytest.approx([centre - 0.002] * 4 + [centre - 0.002 * ratio] * 4, abs=1e-8)
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


@pytest.mark.parametrize("ramp", [0, 4])
def test_the_plans_envelope_opens_after_the_start_and_keeps_the_offset_range(ramp):
    """The planner's bounds: the thrust within 1 +- thrust_envelope load levels and the tip within +- offset_envelope
    of its range; with ramp_periods they open linearly over that many periods after the start (variants of the
    tuning rounds)."""
    config = make_config(None)
    controller = MPCController(bank_size=4, samples=4, elites=2, iterations=1, horizon=4, start_periods=2,
                               replan_every=1, thrust_envelope=0.4, offset_envelope=0.5, ramp_periods=ramp)
    controller.reset(40.0, config)
    obs = np.zeros(15, dtype=np.float32)
    highs = []
    for _ in range(2 + 6):
        controller.act(obs)
        highs.append(controller.planner.high)
    full = (0.4, 0.5)
    if ramp == 0:
        assert all(h == pytest.approx(full) for h in highs)
    else:  # periods 3-6 after a 2-period start: 1/4, 2/4, 3/4, 1 of the envelope, then 1
        assert [h[1] for h in highs[2:]] == pytest.approx([0.125, 0.25, 0.375, 0.5, 0.5, 0.5])
        assert [h[0] for h in highs[2:]] == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.4, 0.4])
    assert controller.planner.low == pytest.approx((-0.4, -0.5))


def test_the_first_plan_comes_replan_every_periods_after_the_start_began_its_last_period():
    """The start is followed like a plan: its last command runs ``replan_every`` periods (the tuned behaviour)."""
    config = make_config(None)
    controller = MPCController(bank_size=4, samples=4, elites=2, iterations=1, horizon=4, block=4, start_periods=8,
                               replan_every=2)
    controller.reset(40.0, config)
    obs = np.zeros(15, dtype=np.float32)
    actions, planned = [], []
    for _ in range(10):
        actions.append(controller.act(obs))
        planned.append(controller.info["planned"])
    assert planned == [False] * 9 + [True]
    assert np.array_equal(actions[8], actions[7])  # period 9 holds the start's last command


def test_the_guard_adds_a_twin_of_the_likeliest_hypothesis_at_the_top_of_the_tip_friction_interval():
    config = make_config(None)
    controller = MPCController(bank_size=8, samples=4, elites=2, iterations=1, horizon=4, guard_weight=0.25)
    controller.reset(40.0, config)
    states, weights = controller.bank.best(4, 3.0)
    guarded, guarded_weights = controller._guarded(states, weights)
    likeliest, twin = states[int(np.argmax(weights))], guarded[-1]
    top = controller.bank.interval(0)[1]
    assert guarded[:-1] == states and len(guarded) == len(states) + 1
    assert guarded_weights == pytest.approx(np.append(0.75 * np.asarray(weights), 0.25))
    assert twin.p[K.P_TANEF] == pytest.approx(max(likeliest.p[K.P_TANEF], np.tan(np.radians(top))))
    assert twin.p[K.P_TANEF] > likeliest.p[K.P_TANEF]  # the prior's interval reaches above any one hypothesis here
    others = np.arange(len(twin.p)) != K.P_TANEF
    assert np.array_equal(twin.p[others], likeliest.p[others]) and np.array_equal(twin.y, likeliest.y)
    controller.tip_friction_deg = 8.0  # a tip the laboratory knows: no twin
    assert controller._guarded(states, weights) == (states, weights)
    controller.tip_friction_deg, controller.guard_weight = None, 0.0
    assert controller._guarded(states, weights) == (states, weights)
