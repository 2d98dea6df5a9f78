"""The batched vector env runs the single env's dynamics exactly (its SB3 adapter: tests/agents/test_sb3_vec_env.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import envs  # noqa: F401 (registers the environments)
from envs import core as S
from envs.triplanar_shear import TriPlanarShearEnv
from envs.vector import TriPlanarShearVectorEnv
from triplanar.outcome import Outcome

N = 4


def actions(steps: int, seed: int = 0) -> np.ndarray:
    # Mostly sliding, sometimes wild: every kind of episode end and the adaptive path occur.
    rng = np.random.default_rng(seed)
    a = np.clip(rng.normal(0.0, 0.35, (steps, N, 2)), -1, 1)
    return a.astype(np.float32)


def test_make_vec_uses_the_batched_env() -> None:
    vec = gym.make_vec("TriPlanarShear-v0", num_envs=3, load_N=30.3)
    assert isinstance(vec, TriPlanarShearVectorEnv)
    assert vec.observation_space.shape == (3, S.OBS_DIM) and vec.action_space.shape == (3, 2)
    assert vec.single_observation_space == S.observation_space()
    obs, info = vec.reset(seed=0)
    assert obs.shape == (3, S.OBS_DIM) and obs.dtype == np.float32 and np.all(obs[:, S.OBS_LOAD] == np.float32(30.3))
    assert set(S.INFO_KEYS) <= set(info)


def _same_ending(info: dict, i: int, inf: dict, te: bool, tr: bool) -> None:
    if te or tr:
        assert info["reason_code"][i] == (Outcome.from_label(inf["reason"]) if te else Outcome.TIME_LIMIT)
        assert info["mimicry_error_mm"][i] == inf["mimicry_error_mm"]


def test_vector_env_equals_n_single_envs(beside_singles) -> None:
    reasons = beside_singles(TriPlanarShearVectorEnv(num_envs=N), [TriPlanarShearEnv() for _ in range(N)],
                             actions(250), 100, _same_ending)
    assert len(reasons) >= 2  # several kinds of ending were compared
