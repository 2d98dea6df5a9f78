"""A trained PPO policy as a controller (``act(obs) -> action``), with the VecNormalize statistics it was trained on;
and the two calls that load SB3's own files, which are pickles (the shipped agents of :mod:`agents.zoo` are not)."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np

from envs.triplanar_shear import ShearConfig

from .controller_base import Controller


def load_untrusted_sb3_zip(path: str | Path, algo: str = "ppo") -> Any:
    """UNPICKLES: an SB3 model zip (``PPO.load``, or sb3-contrib's ``RecurrentPPO.load`` for ``algo="recurrent"``).
    The zip holds cloudpickled objects, and unpickling runs the code in them: call this only on a file you made or
    trust, by its path. The shipped agents (:mod:`agents.zoo`) never go through it."""
    if algo == "recurrent":
        from sb3_contrib import RecurrentPPO as algo_class
    else:
        from stable_baselines3 import PPO as algo_class  # torch only when a policy is used
    return algo_class.load(str(path), device="cpu")


def load_untrusted_vecnormalize(path: str | Path) -> Any:
    """UNPICKLES: a ``vecnormalize.pkl`` (a VecNormalize saved without its env). Unpickling runs the code in the
    file: call this only on a file you made or trust, by its path."""
    with open(path, "rb") as f:
        return pickle.load(f)


class PPOController(Controller):
    """Deterministic actions of a stable-baselines3 PPO model on observations normalised as in training."""

    env_overrides: dict[str, Any] = {}

    def __init__(self, model: Any, normalizer: Any | None = None, name: str = "PPO"):
        self.model, self.normalizer, self.name = model, normalizer, name

    @classmethod
    def load(cls, model_path: str | Path, vecnormalize_path: str | Path | None = None, name: str = "PPO"
             ) -> PPOController:
        """Load a trained policy. UNPICKLES both files (:func:`load_untrusted_sb3_zip`,
        :func:`load_untrusted_vecnormalize`), which runs the code in them: load only files you made or trust."""
        normalizer = load_untrusted_vecnormalize(vecnormalize_path) if vecnormalize_path is not None else None
        return cls(load_untrusted_sb3_zip(model_path), normalizer, name)

    def setup(self, config: ShearConfig) -> None:
        """Deprecated: ``reset(load_N, config)`` (nothing to set up)."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self.normalizer is not None:
            obs = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32))
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)
