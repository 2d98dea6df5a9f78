"""The stable-baselines3 adapter over the batched env (agents/sb3_vec_env.py) runs the single env's dynamics
exactly, with SB3's same-step autoreset."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.sb3_vec_env import ShearSB3VecEnv
from envs import core as S
from envs.triplanar_shear import TriPlanarShearEnv


N = 4


def actions(steps: int, seed: int = 0) -> np.ndarray:
    """The batched env tests' random actions (tests/envs/test_env_vector.py): mostly sliding, sometimes wild."""
    rng = np.random.default_rng(seed)
    return np.clip(rng.normal(0.0, 0.35, (steps, N, 2)), -1, 1).astype(np.float32)


def test_sb3_adapter_equals_single_envs_with_same_step_reset() -> None:
    vec = ShearSB3VecEnv(N, load_levels=(27.8, 40.0, 55.6))
    vec.seed(7)
    obs = vec.reset()
    singles = [TriPlanarShearEnv(load_levels=(27.8, 40.0, 55.6)) for _ in range(N)]
    for i, env in enumerate(singles):
        assert np.array_equal(obs[i], env.reset(seed=7 + i)[0])
    episodes = 0
    for batch in actions(200, seed=3):
        obs, rewards, dones, infos = vec.step(batch)
        assert rewards.dtype == np.float32 and len(infos) == N
        for i, env in enumerate(singles):
            o, r, te, tr, inf = env.step(batch[i])
            assert rewards[i] == np.float32(r) and dones[i] == (te or tr)
            if te or tr:
                episodes += 1
                assert np.array_equal(infos[i]["terminal_observation"], o)
                assert infos[i]["TimeLimit.truncated"] == (tr and not te)
                assert infos[i]["is_success"] == inf["is_success"] and infos[i]["reason"] == inf["reason"]
                o = env.reset()[0]
            else:
                assert infos[i] == {}
            assert np.array_equal(obs[i], o)
    assert episodes >= N


def test_sb3_adapter_row_options_and_api() -> None:
    loads = [27.8, 40.0]
    vec = ShearSB3VecEnv(2, row_options=[{"load_N": f} for f in loads], seed=0)
    obs = vec.reset()
    assert np.allclose(obs[:, S.OBS_LOAD], loads)
    assert vec.get_attr("render_mode") == [None, None] and vec.env_is_wrapped(gym.Wrapper) == [False, False]
    with pytest.raises(ValueError):
        ShearSB3VecEnv(2, row_options=[{}])


@pytest.mark.parametrize("mode", ["bench", "state"])
def test_sb3_adapter_over_batched_v1_terminal_observations_and_autoreset(mode: str) -> None:
    from gymnasium.wrappers import FlattenObservation, FrameStackObservation

    from agents.sb3_vec_env import bench_vec_env
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    kwargs = dict(observation_mode=mode, randomize=True, latency_s=0.01)
    vec = bench_vec_env(N, seed=11, frame_stack=3, **kwargs)
    obs = vec.reset()
    singles = [FlattenObservation(FrameStackObservation(TriPlanarShearV1Env(**kwargs), 3)) for _ in range(N)]
    assert vec.observation_space == singles[0].observation_space
    for i, env in enumerate(singles):
        assert np.array_equal(obs[i], env.reset(seed=11 + i)[0])
    episodes = 0
    for batch in np.clip(np.random.default_rng(5).normal(0.0, 0.9, (300, N, 2)), -1, 1).astype(np.float32):
        obs, rewards, dones, infos = vec.step(batch)
        for i, env in enumerate(singles):
            o, r, te, tr, inf = env.step(batch[i])
            assert rewards[i] == np.float32(r) and dones[i] == (te or tr)
            if te or tr:
                episodes += 1
                assert np.array_equal(infos[i]["terminal_observation"], o)   # the stack at the episode's end
                assert infos[i]["TimeLimit.truncated"] == (tr and not te)
                assert infos[i]["reason"] == inf["reason"] and infos[i]["mimicry_error_mm"] == inf["mimicry_error_mm"]
                o = env.reset()[0]   # same-step autoreset: the next episode's first stack
            else:
                assert infos[i] == {}
            assert np.array_equal(obs[i], o)
    assert episodes >= 2 * N
