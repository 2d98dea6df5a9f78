"""A stable-baselines3 ``VecEnv`` over the batched TriPlanarShear arrays (:class:`envs.vector.ShearBatch`).

It lives with the agents, not in :mod:`envs`, because stable-baselines3 (and torch with it) is an agent's
dependency: ``import envs`` and ``gym.make_vec("TriPlanarShear-v0")`` work without them.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv

from envs import triplanar_shear as S
from envs.vector import ShearBatch
from triplanar.outcome import TRAVEL

__all__ = ["ShearSB3VecEnv"]


class ShearSB3VecEnv(VecEnv):
    """stable-baselines3 ``VecEnv`` over a :class:`ShearBatch` (same-step autoreset, as SB3's ``DummyVecEnv``).

    ``row_options`` fixes reset options per environment, e.g. one load level each for evaluation:
    ``ShearSB3VecEnv(12, row_options=[{"load_N": f} for f in PAPER_LOADS_N])``.

    At an episode's end ``infos[i]`` has ``terminal_observation``, ``TimeLimit.truncated``, ``is_success``,
    ``reason`` and ``mimicry_error_mm``; otherwise it is empty.
    """

    def __init__(self, num_envs: int, config: S.ShearConfig | None = None, seed: int | None = None,
                 row_options: Sequence[dict[str, Any] | None] | None = None, **kwargs: Any):
        config = S.make_config(config, **kwargs)
        self.batch = ShearBatch(num_envs, config)
        if row_options is not None:
            if len(row_options) != num_envs:
                raise ValueError(f"row_options needs {num_envs} entries, got {len(row_options)}")
            self.batch.row_options = list(row_options)
        self.config = config
        self.render_mode = None
        super().__init__(num_envs, S.observation_space(), S.action_space())
        if seed is not None:
            self.seed(seed)
        self._actions = np.zeros((num_envs, 2))
        self._all = np.ones(num_envs, dtype=np.bool_)

    def reset(self):
        seeds = self._seeds
        if any(s is not None for s in seeds):
            self.batch.seed(seeds)
        options = self._options[0] if self._options and self._options[0] else None
        self.batch.reset_rows(np.arange(self.num_envs), options)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{"load_N": d.load_N} for d in self.batch.draws]
        return self.batch.OBS.astype(np.float32)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions[:] = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 2)

    def step_wait(self):
        batch = self.batch
        codes = batch.step(self._actions, self._all)
        obs = batch.OBS.astype(np.float32)
        rewards = batch.INF[:, S.IN_REWARD].astype(np.float32)
        terminated = codes > 0
        truncated = batch.INF[:, S.IN_TRUNC] != 0
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(dones)
        for i in ended:
            infos[i] = {"terminal_observation": obs[i].copy(), "TimeLimit.truncated": bool(truncated[i]),
                        "is_success": bool(codes[i] == TRAVEL), "reason": batch.reason(i),
                        "mimicry_error_mm": float(batch.INF[i, S.IN_ERR]), "travel_m": float(batch.INF[i, S.IN_TRAVEL]),
                        "load_N": float(batch.INF[i, S.IN_LOAD])}
        if len(ended):
            batch.reset_rows(ended)
            obs[ended] = batch.OBS[ended]
        return obs, rewards, dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return [getattr(self, method_name)(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]
