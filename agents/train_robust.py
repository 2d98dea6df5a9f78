"""Robust PPO: trained on ``TriPlanarShear-v1`` in bench mode under randomisation (unknown specimens), with history
either from a 4-frame stack (``algo="ppo"``: stable-baselines3's PPO on ``gymnasium.wrappers.FrameStackObservation``,
flattened: 60 inputs; the controller ``ppo_robust``) or from a recurrent policy (``algo="recurrent"``: sb3-contrib's
``RecurrentPPO`` with ``MlpLstmPolicy`` on the 15 bench observations; the controller ``ppo_recurrent``).

``train_seeds(out_dir, seeds, timesteps, executor=...)`` trains one run per seed through the project's executor
(:func:`triplanar.workbench.executor.run_tasks`; a finished seed is read back, not trained again). Each run writes
``OUT/seed_S/``: ``final_model.zip`` and ``vecnormalize.pkl`` (temporary name, then rename), ``learning_curve.csv``
(at every evaluation: timesteps, wall seconds, and on ``CURVE_BENCHES`` tuning benches, never the held-out ones,
the success rate, mimicry error over successful episodes and the score of :mod:`agents.heldout`) and ``done.json``.
While it trains, a run saves a checkpoint every ``checkpoint_freq`` steps (``OUT/seed_S/checkpoint/``: the model,
the normalisation statistics and the learning curve so far); an interrupted run continues from its last checkpoint
(its remaining steps are then drawn from a generator seeded anew, so a resumed run is not bitwise the run an
uninterrupted one would have been). The model files are pickles: load only runs you trained.
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
N_ENVS = 4
CHECKPOINT_FREQ = 50_000
PPO_KWARGS = dict(learning_rate=3e-4, n_steps=512, batch_size=256, n_epochs=10, gamma=0.99, gae_lambda=0.95,
                  clip_range=0.2, ent_coef=0.0, max_grad_norm=0.5,
                  policy_kwargs=dict(net_arch=[64, 64], log_std_init=-1.0))
# RecurrentPPO: the same PPO settings; one LSTM layer of 64 cells for the actor and one for the critic, then the
# same 64x64 heads. The buffer of 4 x 512 steps is cut into sequences at episode starts; batch_size counts steps.
RECURRENT_KWARGS = dict(PPO_KWARGS, policy_kwargs=dict(net_arch=[64, 64], log_std_init=-1.0, lstm_hidden_size=64,
                                                       n_lstm_layers=1, enable_critic_lstm=True))
ALGOS = {"ppo": "ppo_robust", "recurrent": "ppo_recurrent"}  # algo -> controller name in the tables


def make_env(env_kwargs: dict[str, Any] | None = None, algo: str = "ppo"):
    """The training env: v1 in bench mode under randomisation; with the frame stack for ``algo="ppo"``."""
    import gymnasium as gym
    from gymnasium.wrappers import FlattenObservation, FrameStackObservation

    import envs  # noqa: F401 (registers the environment)
    kwargs = {"observation_mode": "bench", "randomize": True, **(env_kwargs or {})}
    env = gym.make("TriPlanarShear-v1", **kwargs)
    if algo == "recurrent":
        return env
    return FlattenObservation(FrameStackObservation(env, FRAMES))


def _algo_class(algo: str):
    if algo == "recurrent":
        from sb3_contrib import RecurrentPPO
        return RecurrentPPO
    from stable_baselines3 import PPO
    return PPO


class RobustPolicy:
    """A trained robust PPO as ``policy(obs) -> action`` on raw bench observations: keeps the frame stack itself
    (filled with the first observation of an episode, as ``FrameStackObservation`` pads)."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_robust"):
        self.model, self.normalizer, self.name = model, normalizer, name
        self.frames: deque = deque(maxlen=FRAMES)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_robust") -> RobustPolicy:
        from stable_baselines3 import PPO
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


class RecurrentPolicy:
    """A trained recurrent PPO (``RecurrentPPO``) as ``policy(obs) -> action`` on raw bench observations: keeps the
    LSTM state itself, reset at each episode's start."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_recurrent"):
        self.model, self.normalizer, self.name = model, normalizer, name
        self.state: Any = None
        self.episode_start = np.ones((1,), dtype=bool)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_recurrent") -> RecurrentPolicy:
        run_dir = Path(run_dir)
        with open(run_dir / "vecnormalize.pkl", "rb") as f:
            normalizer = pickle.load(f)
        return cls(_algo_class("recurrent").load(str(run_dir / "final_model.zip"), device="cpu"), normalizer, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.state = None
        self.episode_start = np.ones((1,), dtype=bool)

    def act(self, obs: np.ndarray) -> np.ndarray:
        normalized = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32)[None, :])
        action, self.state = self.model.predict(normalized, state=self.state, episode_start=self.episode_start,
                                                deterministic=True)
        self.episode_start = np.zeros((1,), dtype=bool)
        return np.asarray(action[0], dtype=np.float32)


def load_policy(run_dir: str | Path, algo: str = "ppo", name: str | None = None) -> RobustPolicy | RecurrentPolicy:
    """A finished run of :func:`train_robust` as a bench controller (``reset``/``act``)."""
    cls = RecurrentPolicy if algo == "recurrent" else RobustPolicy
    return cls.load(run_dir, name=name or ALGOS[algo])


def evaluate_policy_on(policy: RobustPolicy | RecurrentPolicy, benches: Sequence[Any], env_kwargs: dict[str, Any] | None = None,
                       bench_set: str = "heldout", tip_friction_deg: float | None = None) -> list[Any]:
    from .heldout import run_episode, with_tip
    return [run_episode(policy, with_tip(b, tip_friction_deg), env_kwargs=env_kwargs, seed=i, bench_set=bench_set,
                        index=i) for i, b in enumerate(benches)]


@dataclass(frozen=True)
class RobustTask:
    out_dir: str
    seed: int
    timesteps: int
    env_kwargs: tuple = ()
    eval_freq: int = 20_000
    algo: str = "ppo"                      # "ppo" (frame stack) or "recurrent" (RecurrentPPO, LSTM)
    checkpoint_freq: int = CHECKPOINT_FREQ


def _atomic(save, path: Path) -> None:
    tmp = path.with_name(path.name + ".tmp")
    save(tmp)
    os.replace(tmp, path)


def train_robust(task: RobustTask) -> dict[str, Any]:
    """Train one seed (module-level and picklable for the executor); returns its summary. Resumes from the run's
    checkpoint if there is one."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from .heldout import TUNING_SEED, random_benches, summarise

    if task.algo not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {task.algo!r}")
    torch.set_num_threads(1)
    env_kwargs = dict(task.env_kwargs)
    run_dir = Path(task.out_dir) / f"seed_{task.seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    done = run_dir / "done.json"
    if done.exists():
        return json.loads(done.read_text())
    algo_cls = _algo_class(task.algo)
    policy_cls = RecurrentPolicy if task.algo == "recurrent" else RobustPolicy
    venv_raw = DummyVecEnv([lambda: make_env(env_kwargs, task.algo) for _ in range(N_ENVS)])
    ckpt = run_dir / "checkpoint"
    rows: list[dict[str, float]] = []
    wall_before = 0.0   # wall seconds spent before the checkpoint this run resumes from
    if (ckpt / "state.json").exists():
        state = json.loads((ckpt / "state.json").read_text())
        rows, wall_before = state["curve"], state["wall_s"]
        venv_raw.seed(task.seed + 7919 * int(state["timesteps"]))   # a fresh stream for the remaining steps
        venv = VecNormalize.load(str(ckpt / "vecnormalize.pkl"), venv_raw)
        model = algo_cls.load(str(ckpt / "model.zip"), env=venv, device="cpu")
    else:
        venv_raw.seed(task.seed)
        venv = VecNormalize(venv_raw, norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=0.99)
        kwargs = RECURRENT_KWARGS if task.algo == "recurrent" else PPO_KWARGS
        policy = "MlpLstmPolicy" if task.algo == "recurrent" else "MlpPolicy"
        model = algo_cls(policy, venv, seed=task.seed, device="cpu", verbose=0, **kwargs)
    curve_benches = random_benches(CURVE_BENCHES, TUNING_SEED + 1, env_kwargs)
    started = time.perf_counter()

    def wall() -> float:
        return wall_before + time.perf_counter() - started

    def evaluate() -> None:
        stats = summarise(evaluate_policy_on(policy_cls(model, venv), curve_benches, env_kwargs, "tuning"))
        rows.append({"timesteps": model.num_timesteps, "wall_s": wall(), **stats})

    def checkpoint() -> None:
        ckpt.mkdir(exist_ok=True)
        _atomic(lambda p: model.save(str(p)), ckpt / "model.zip")
        _atomic(lambda p: venv.save(str(p)), ckpt / "vecnormalize.pkl")
        _atomic(lambda p: p.write_text(json.dumps({"timesteps": model.num_timesteps, "wall_s": wall(),
                                                   "curve": rows})), ckpt / "state.json")

    class Curve(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next_eval = (rows[-1]["timesteps"] + task.eval_freq) if rows else 0
            self.next_ckpt = model.num_timesteps + task.checkpoint_freq

        def _on_step(self) -> bool:
            if self.next_eval <= self.num_timesteps < task.timesteps:
                self.next_eval += task.eval_freq
                evaluate()
            return True

        def _on_rollout_end(self) -> None:
            if self.num_timesteps >= self.next_ckpt and self.num_timesteps < task.timesteps:
                self.next_ckpt += task.checkpoint_freq
                checkpoint()

    remaining = task.timesteps - model.num_timesteps
    if remaining > 0:
        model.learn(total_timesteps=remaining, callback=Curve(), reset_num_timesteps=model.num_timesteps == 0)
    evaluate()

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
    summary = {"seed": task.seed, "algo": task.algo, "timesteps": int(model.num_timesteps), "wall_s": wall(),
               "run_dir": str(run_dir)}
    _atomic(lambda p: p.write_text(json.dumps(summary)), done)
    return summary


def seed_tasks(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 100_000, *,
               env_kwargs: dict[str, Any] | None = None, eval_freq: int = 20_000, algo: str = "ppo",
               checkpoint_freq: int = CHECKPOINT_FREQ) -> list[RobustTask]:
    """The tasks of :func:`train_seeds` (one per seed), for callers that run several kinds in one executor call."""
    if timesteps <= 0 or not math.isfinite(timesteps):
        raise ValueError(f"timesteps must be positive, got {timesteps}")
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {algo!r}")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    return [RobustTask(str(out_dir), int(s), int(timesteps), tuple(sorted((env_kwargs or {}).items())), eval_freq,
                       algo, checkpoint_freq) for s in seeds]


def train_seeds(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 100_000, *,
                env_kwargs: dict[str, Any] | None = None, executor: ExecutorLike = None,
                eval_freq: int = 20_000, algo: str = "ppo") -> list[dict[str, Any]]:
    """One robust PPO run per seed (``algo``: ``"ppo"`` frame stack, ``"recurrent"`` LSTM), through the project's
    executor (resumable per seed, and inside a seed from its last checkpoint)."""
    tasks = seed_tasks(out_dir, seeds, timesteps, env_kwargs=env_kwargs, eval_freq=eval_freq, algo=algo)
    return run_tasks(train_robust, tasks, executor=executor, progress=True, desc=f"{ALGOS[algo]} seeds",
                     checkpoint=TaskCheckpoint(Path(out_dir) / "tasks"))
