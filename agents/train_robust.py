"""Robust PPO: trained on ``TriPlanarShear-v1`` in bench mode under randomisation (unknown specimens), with history
from a 4-frame stack (``gymnasium.wrappers.FrameStackObservation``, flattened: 60 inputs).

``train_seeds(out_dir, seeds, timesteps, executor=...)`` trains one run per seed through the project's executor
(:func:`triplanar.workbench.executor.run_tasks`; a finished seed is read back, not trained again). Each run writes
``OUT/seed_S/``: ``final_model.zip`` and ``vecnormalize.pkl`` (temporary name, then rename), ``learning_curve.csv``
(at every evaluation: timesteps, wall seconds, and on ``CURVE_BENCHES`` tuning benches, never the held-out ones,
the success rate, mimicry error over successful episodes and the score of :mod:`agents.heldout`) and ``done.json``.
An interrupted seed starts again from zero (checkpointing inside a run is :mod:`agents.train_ppo`'s, for v0).
The model files are pickles: load only runs you trained.
"""

from __future__ import annotations

import csv
import json
import math
import os
import pickle
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from triplanar.workbench.executor import ExecutorLike, TaskCheckpoint, run_tasks

FRAMES = 4
CURVE_BENCHES = 10
PPO_KWARGS = dict(learning_rate=3e-4, n_steps=512, batch_size=256, n_epochs=10, gamma=0.99, gae_lambda=0.95,
                  clip_range=0.2, ent_coef=0.0, max_grad_norm=0.5,
                  policy_kwargs=dict(net_arch=[64, 64], log_std_init=-1.0))


def make_env(env_kwargs: dict[str, Any] | None = None):
    import gymnasium as gym  # noqa: PLC0415
    from gymnasium.wrappers import FlattenObservation, FrameStackObservation  # noqa: PLC0415

    import envs  # noqa: F401, PLC0415
    kwargs = {"observation_mode": "bench", "randomize": True, **(env_kwargs or {})}
    return FlattenObservation(FrameStackObservation(gym.make("TriPlanarShear-v1", **kwargs), FRAMES))


class RobustPolicy:
    """A trained robust PPO as ``policy(obs) -> action`` on raw bench observations: keeps the frame stack itself
    (filled with the first observation of an episode, as ``FrameStackObservation`` pads)."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_robust"):
        self.model, self.normalizer, self.name = model, normalizer, name
        self.frames: deque = deque(maxlen=FRAMES)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_robust") -> RobustPolicy:
        from stable_baselines3 import PPO  # noqa: PLC0415
        run_dir = Path(run_dir)
        with open(run_dir / "vecnormalize.pkl", "rb") as f:
            normalizer = pickle.load(f)
        return cls(PPO.load(str(run_dir / "final_model.zip"), device="cpu"), normalizer, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.frames.clear()

    def act(self, obs: np.ndarray) -> np.ndarray:
        if not self.frames:
            self.frames.extend([obs] * FRAMES)
        else:
            self.frames.append(obs)
        stacked = np.concatenate(list(self.frames)).astype(np.float32)
        action, _ = self.model.predict(self.normalizer.normalize_obs(stacked), deterministic=True)
        return np.asarray(action, dtype=np.float32)


def evaluate_policy_on(policy: RobustPolicy, benches: Sequence[Any], env_kwargs: dict[str, Any] | None = None,
                       bench_set: str = "heldout", tip_friction_deg: float | None = None) -> list[Any]:
    from .heldout import run_episode, with_tip  # noqa: PLC0415
    return [run_episode(policy, with_tip(b, tip_friction_deg), env_kwargs=env_kwargs, seed=i, bench_set=bench_set,
                        index=i) for i, b in enumerate(benches)]


@dataclass(frozen=True)
class RobustTask:
    out_dir: str
    seed: int
    timesteps: int
    env_kwargs: tuple = ()
    eval_freq: int = 20_000


def _atomic(save, path: Path) -> None:
    tmp = path.with_name(path.name + ".tmp")
    save(tmp)
    os.replace(tmp, path)


def train_robust(task: RobustTask) -> dict[str, Any]:
    """Train one seed (module-level and picklable for the executor); returns its summary."""
    import torch  # noqa: PLC0415
    from stable_baselines3 import PPO  # noqa: PLC0415
    from stable_baselines3.common.callbacks import BaseCallback  # noqa: PLC0415
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: PLC0415

    from .heldout import TUNING_SEED, random_benches, summarise  # noqa: PLC0415

    torch.set_num_threads(1)
    env_kwargs = dict(task.env_kwargs)
    run_dir = Path(task.out_dir) / f"seed_{task.seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    done = run_dir / "done.json"
    if done.exists():
        return json.loads(done.read_text())
    venv = DummyVecEnv([lambda: make_env(env_kwargs) for _ in range(4)])
    venv.seed(task.seed)
    venv = VecNormalize(venv, norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=0.99)
    model = PPO("MlpPolicy", venv, seed=task.seed, device="cpu", verbose=0, **PPO_KWARGS)
    curve_benches = random_benches(CURVE_BENCHES, TUNING_SEED + 1, env_kwargs)
    rows: list[dict[str, float]] = []
    started = time.perf_counter()

    class Curve(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next = 0

        def _on_step(self) -> bool:
            if self.next <= self.num_timesteps < task.timesteps:
                self.next += task.eval_freq
                policy = RobustPolicy(model, venv)
                stats = summarise(evaluate_policy_on(policy, curve_benches, env_kwargs, "tuning"))
                rows.append({"timesteps": self.num_timesteps, "wall_s": time.perf_counter() - started, **stats})
            return True

    model.learn(total_timesteps=task.timesteps, callback=Curve())
    stats = summarise(evaluate_policy_on(RobustPolicy(model, venv), curve_benches, env_kwargs, "tuning"))
    rows.append({"timesteps": model.num_timesteps, "wall_s": time.perf_counter() - started, **stats})

    def write_curve(path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    _atomic(write_curve, run_dir / "learning_curve.csv")
    _atomic(lambda p: model.save(str(p)), run_dir / "final_model.zip")
    venv.venv = None  # the statistics only (as agents.train_ppo saves them)

    def dump(p: Path) -> None:
        with open(p, "wb") as f:
            pickle.dump(venv, f)

    _atomic(dump, run_dir / "vecnormalize.pkl")
    summary = {"seed": task.seed, "timesteps": int(model.num_timesteps), "wall_s": time.perf_counter() - started,
               "run_dir": str(run_dir)}
    _atomic(lambda p: p.write_text(json.dumps(summary)), done)
    return summary


def train_seeds(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 100_000, *,
                env_kwargs: dict[str, Any] | None = None, executor: ExecutorLike = None,
                eval_freq: int = 20_000) -> list[dict[str, Any]]:
    """One robust PPO run per seed, through the project's executor (resumable per seed)."""
    if timesteps <= 0 or not math.isfinite(timesteps):
        raise ValueError(f"timesteps must be positive, got {timesteps}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tasks = [RobustTask(str(out_dir), int(s), int(timesteps), tuple(sorted((env_kwargs or {}).items())), eval_freq)
             for s in seeds]
    return run_tasks(train_robust, tasks, executor=executor, progress=True, desc="robust PPO seeds",
                     checkpoint=TaskCheckpoint(out_dir / "tasks"))
