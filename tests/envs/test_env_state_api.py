"""The envs' state as a public API (MuJoCo's ``state_vector``/``set_state``): ``get_state`` copies an episode's whole
state out, ``set_state`` loads it into another env of the same configuration, and the two then step alike, bitwise."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.heldout import nominal_benches
from envs.base import ShearState
from envs.core import OBS_POS, OBS_REF
from envs.triplanar_shear import TriPlanarShearEnv
from envs.triplanar_shear_v1 import BenchState, TriPlanarShearV1Env

ACTIONS = np.random.default_rng(7).uniform(-1, 1, (6, 2)).astype(np.float32)


def _steps(env, actions):
    return [env.step(a)[:3] for a in actions]


def _same(a, b):
    for (obs_a, r_a, t_a), (obs_b, r_b, t_b) in zip(a, b):
        np.testing.assert_array_equal(obs_a, obs_b)
        assert r_a == r_b and t_a == t_b


def test_v1_state_moves_between_envs_bitwise():
    bench = nominal_benches([40.0])[0]
    source, target = (TriPlanarShearV1Env(observation_mode="state") for _ in range(2))
    source.reset(seed=0, options={"bench": bench})
    target.reset(seed=0, options={"bench": nominal_benches([30.0])[0]})   # another episode, overwritten below
    _steps(source, ACTIONS[:3])
    state = source.get_state()
    assert isinstance(state, BenchState)
    state.y[:] = np.nan                  # a copy: the env's arrays are untouched
    assert np.all(np.isfinite(source.get_state().y))
    target.set_state(source.get_state())
    _same(_steps(source, ACTIONS[3:]), _steps(target, ACTIONS[3:]))


def test_v0_state_moves_between_envs_bitwise():
    source, target = TriPlanarShearEnv(load_N=41.7), TriPlanarShearEnv(load_N=41.7)
    source.reset(seed=0)
    target.reset(seed=0)
    _steps(source, ACTIONS[:2])
    state = source.get_state()
    assert type(state) is ShearState
    target.set_state(state)
    _same(_steps(source, ACTIONS[2:]), _steps(target, ACTIONS[2:]))


def test_set_state_refuses_another_bench_and_needs_an_episode():
    bench = nominal_benches([40.0])[0]
    env, other = TriPlanarShearV1Env(), TriPlanarShearV1Env(latency_s=0.0)
    with pytest.raises(gym.error.ResetNeeded, match="get_state"):
        env.get_state()
    env.reset(seed=0, options={"bench": bench})
    other.reset(seed=0, options={"bench": bench})
    with pytest.raises(ValueError, match="another bench"):
        env.set_state(other.get_state())
    with pytest.raises(TypeError, match="BenchState"):
        env.set_state(ShearState(**{k: v for k, v in vars(other.get_state()).items()
                                    if k in ShearState.__dataclass_fields__}))


def test_v1_start_state_is_the_resets_and_without_reference_moves_alike():
    """``start_state`` is the state ``reset`` begins from, without an episode; without the case-C reference the
    block moves, is observed in position and ends exactly as with it (what a fit to measured positions uses), only
    the reference (zeros) and what is read against it differ."""
    bench = nominal_benches([40.0])[0]
    env = TriPlanarShearV1Env(observation_mode="state")
    obs, _ = env.reset(seed=0, options={"bench": bench})
    reset_state = env.get_state()
    state, start_obs = env.start_state(bench)
    for name in ("y", "p", "modes", "armed", "st", "ref", "cfg", "bc", "bs", "queue"):
        np.testing.assert_array_equal(getattr(state, name), getattr(reset_state, name), err_msg=name)
    np.testing.assert_array_equal(start_obs.astype(np.float32), obs)
    bare, bare_obs = env.start_state(bench, reference=False)
    assert not bare.ref.any() and reset_state.ref.any()
    np.testing.assert_array_equal(bare.y, state.y)
    np.testing.assert_array_equal(bare_obs[OBS_POS:OBS_POS + 9], start_obs[OBS_POS:OBS_POS + 9])
    twin = TriPlanarShearV1Env(observation_mode="state")
    twin.reset(seed=0, options={"bench": bench})
    twin.set_state(bare)
    for action in np.tile(ACTIONS, (4, 1)):
        full, full_r, full_end = env.step(action)[:3]
        moved, moved_r, moved_end = twin.step(action)[:3]
        np.testing.assert_array_equal(moved[OBS_POS:OBS_POS + 18], full[OBS_POS:OBS_POS + 18])   # positions, speeds
        assert moved_end == full_end
        if full_end:
            break
    assert not np.array_equal(moved[OBS_REF:OBS_REF + 9], full[OBS_REF:OBS_REF + 9])
    with pytest.raises(TypeError, match="start_state: bench"):
        env.start_state("nominal")
