"""A trained PPO policy as a controller (``act(obs) -> action``), with the VecNormalize statistics it was trained on."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np

from envs.triplanar_shear import ShearConfig


class PPOController:
    """Deterministic actions of a stable-baselines3 PPO model on observations normalised as in training."""

    env_overrides: dict[str, Any] = {}

    def __init__(self, model: Any, normalizer: Any | None = None, name: str = "PPO"):
        self.model, self.normalizer, self.name = model, normalizer, name

    @classmethod
    def load(cls, model_path: str | Path, vecnormalize_path: str | Path | None = None, name: str = "PPO"
             ) -> PPOController:
        """Load a trained policy. Both files are unpickled (cloudpickle, pickle), which runs the code in them:
        load only files you made or that come from a trusted source."""
        from stable_baselines3 import PPO  # torch only when a policy is used
        model = PPO.load(str(model_path), device="cpu")
        normalizer = None
        if vecnormalize_path is not None:
            with open(vecnormalize_path, "rb") as f:
                normalizer = pickle.load(f)  # a VecNormalize without its venv: statistics and clipping
        return cls(model, normalizer, name)

    def setup(self, config: ShearConfig) -> None:
        pass

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self.normalizer is not None:
            obs = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32))
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)
