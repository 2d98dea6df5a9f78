"""Two tasks under two names (the ideal bench, the realistic bench); the first published ids keep working and make
the same classes, and the ids the docs lead with make no warning."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers, as import triplanar does)
from triplanar.gym_registration import IDEAL_ID, REALISTIC_ID


@pytest.mark.parametrize("new, old", [(IDEAL_ID, "TriPlanarShear-v0"), (REALISTIC_ID, "TriPlanarShear-v1")])
def test_new_name_makes_the_published_ids_env_without_a_warning(new: str, old: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(new)
        vec = gym.make_vec(new, num_envs=2, vectorization_mode="vector_entry_point")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # (Gymnasium notes TriPlanarShear-v0 as older than -v1: one name to it)
        published = gym.make(old)
        published_vec = gym.make_vec(old, num_envs=2, vectorization_mode="vector_entry_point")
    assert type(env.unwrapped) is type(published.unwrapped) and type(vec) is type(published_vec)
    assert env.spec.reward_threshold == published.spec.reward_threshold == -1.0
    assert env.spec.max_episode_steps == published.spec.max_episode_steps
    a, _ = env.reset(seed=3)
    b, _ = published.reset(seed=3)
    action = np.array([0.3, -0.2], dtype=np.float32)
    assert np.array_equal(a, b) and np.array_equal(env.step(action)[0], published.step(action)[0])
