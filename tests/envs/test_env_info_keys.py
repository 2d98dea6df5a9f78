"""``info`` has the same keys however the env runs: the batched env's ``reason_code`` and the single env's
``reason`` are in both (``gym.make_vec`` in sync mode stacks the single env's), and v0's reset info has its step
info's keys."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers)
from envs.triplanar_shear import TriPlanarShearEnv
from triplanar.outcome import Outcome


@pytest.mark.parametrize("env_id", ["TriPlanarShearIdeal-v0", "TriPlanarShearRealistic-v0"])
def test_batched_and_sync_infos_have_reason_and_reason_code(env_id: str) -> None:
    kwargs = {"load_N": 27.8, "time_limit_s": 0.02}
    infos = {}
    for mode in ("vector_entry_point", "sync"):
        vec = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode, **kwargs)
        vec.reset(seed=0)
        for _ in range(3):   # the third step ends both episodes at the time limit
            *_, info = vec.step(np.zeros((2, 2), dtype=np.float32))
        infos[mode] = info
    batched, sync = infos["vector_entry_point"], infos["sync"]
    for info in (batched, sync):
        assert list(info["reason"]) == ["time_limit"] * 2
        assert list(info["reason_code"]) == [Outcome.TIME_LIMIT] * 2
    assert {k for k in sync if not k.startswith("_")} >= set(batched)


def test_v0_reset_info_has_the_step_keys() -> None:
    env = TriPlanarShearEnv(load_N=32.5)
    _, reset_info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(np.zeros(2, dtype=np.float32))
    assert set(reset_info) == set(step_info)
    assert reset_info["load_N"] == 32.5 and reset_info["reason"] == "" and reset_info["reason_code"] == 0
