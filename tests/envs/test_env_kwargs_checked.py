"""Env arguments are checked where they enter, each refused with a message naming it: a boolean is a boolean, a
load level is positive whether or not the episode draws its own load, the latency queue's size is bounded before it
is allocated, and a batched env's argument given to single envs says where it belongs."""

from __future__ import annotations

import gymnasium as gym
import pytest

import envs  # noqa: F401  (registers)
from envs.triplanar_shear import TriPlanarShearEnv
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from envs.vector_v1 import TriPlanarShearV1VectorEnv


@pytest.mark.parametrize("make", [TriPlanarShearV1Env, TriPlanarShearV1VectorEnv])
def test_randomize_must_be_a_boolean(make) -> None:
    with pytest.raises(ValueError, match="randomize must be True or False, got 'no'"):
        make(randomize="no")


@pytest.mark.parametrize("make, kwargs", [(TriPlanarShearV1Env, {"randomize": True}),
                                          (TriPlanarShearV1VectorEnv, {"randomize": True}),
                                          (TriPlanarShearEnv, {"load_N": 27.8})])
def test_a_negative_load_level_is_refused_even_when_unused(make, kwargs) -> None:
    with pytest.raises(ValueError, match="load_levels must be a sequence of positive loads"):
        make(load_levels=[-5], **kwargs)
    with pytest.raises(ValueError, match="load_N must be a positive number"):
        TriPlanarShearEnv(load_N=-27.8)


@pytest.mark.parametrize("make", [TriPlanarShearV1Env, TriPlanarShearV1VectorEnv])
def test_latency_is_bounded_before_allocation(make) -> None:
    with pytest.raises(ValueError, match=r"latency_s must lie in \[0, time_limit_s = 2 s\].*got 1000000000.0"):
        make(latency_s=1e9)   # (3 TB of latency queue if allocated)


def test_frame_stack_in_sync_mode_is_refused_by_name() -> None:
    with pytest.raises(TypeError, match="frame_stack is an argument of the batched env only"):
        gym.make_vec("TriPlanarShearRealistic-v0", num_envs=2, vectorization_mode="sync", frame_stack=4)


def test_make_vec_passes_the_registered_episode_length() -> None:
    vec = gym.make_vec("TriPlanarShearRealistic-v0", num_envs=2, vectorization_mode="vector_entry_point")
    assert vec.spec.max_episode_steps == 399
    with pytest.raises(ValueError, match="max_episode_steps must be None or an integer >= 799"):
        gym.make_vec("TriPlanarShearRealistic-v0", num_envs=2, vectorization_mode="vector_entry_point",
                     time_limit_s=4.0)
    gym.make_vec("TriPlanarShearRealistic-v0", num_envs=2, vectorization_mode="vector_entry_point",
                 time_limit_s=4.0, max_episode_steps=None)
