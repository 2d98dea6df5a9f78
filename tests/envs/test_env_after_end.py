"""After an episode ends, ``step`` warns as Gymnasium's CartPole does; after a ``reset`` that raised, ``step`` is
refused until a reset succeeds (it must not go on with the previous episode)."""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from typing import Iterator

import gymnasium as gym
import numpy as np
import pytest

from envs.triplanar_shear import TriPlanarShearEnv
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

ZERO = np.zeros(2, dtype=np.float32)


@pytest.mark.parametrize("make", [lambda: TriPlanarShearEnv(load_N=27.8, time_limit_s=0.02),
                                  lambda: TriPlanarShearV1Env(time_limit_s=0.02)])
def test_step_after_the_end_warns_once(make) -> None:
    env = make()
    env.reset(seed=0)
    ends = [env.step(ZERO)[3] for _ in range(3)]   # 4 periods, the first in reset
    assert ends == [False, False, True]
    with pytest.warns(UserWarning, match="calling 'step\\(\\)' even though this environment has already returned"):
        env.step(ZERO)
    with _no_warning():
        env.step(ZERO)                             # once per episode, as CartPole
    env.reset(seed=1)
    with _no_warning():
        env.step(ZERO)


@contextmanager
def _no_warning() -> Iterator[None]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


@pytest.mark.parametrize("make, bad_options", [
    (lambda: TriPlanarShearEnv(load_N=27.8), {"load_N": -1.0}),
    (lambda: TriPlanarShearV1Env(), {"unknown": 1})])
def test_a_failed_reset_leaves_no_episode_to_step(make, bad_options) -> None:
    env = make()
    env.reset(seed=0)
    env.step(ZERO)
    with pytest.raises(ValueError):
        env.reset(seed=1, options=bad_options)
    with pytest.raises(gym.error.ResetNeeded, match="last reset\\(\\) raised"):
        env.step(ZERO)
    env.reset(seed=1)
    env.step(ZERO)
