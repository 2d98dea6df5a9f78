"""The run folder of a ``TriPlanarShear-v0`` training (layout ``loads``, :mod:`agents.train_config`): evaluations at
fixed loads and SB3-style checkpoints. ``OUT/seed_S`` holds:

* ``checkpoints/ppo_<N>_steps.zip`` + ``ppo_vecnormalize_<N>_steps.npz``: resumable checkpoints, each written to a
  temporary name and renamed when complete (the statistics as plain arrays, :mod:`agents.checkpoint_files`). A
  resumed run continues from the newest one that loads (a damaged one is skipped with a warning); rows of
  ``learning_curve.csv`` written after it are dropped, as they are written again;
* ``tb/``: TensorBoard logs (or under ``tensorboard_log``): SB3's ``rollout/*`` and ``train/*``,
  ``rollout/error_mm_mean`` (:mod:`agents.train_logging`) and ``mimicry/*`` from the evaluations;
* ``eval/``: EvalCallback's ``evaluations.npz`` and ``best_model.zip`` (highest mean return over the loads);
* ``learning_curve.csv``: at every evaluation, timesteps, cumulative wall-clock seconds, and the deterministic
  policy's mimicry error (mm) and outcome at each of ``eval_loads``;
* ``config.json``, ``final_model.zip``, ``vecnormalize.pkl`` and ``done.json`` (:mod:`agents.trainer`).

A checkpoint is resumed only in a run the caller named, or when its statistics carry the task's ``token``.
"""

from __future__ import annotations

import csv
import re
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from triplanar.atomic import write_atomic

from .checkpoint_files import CheckpointError, load_normalizer, save_normalizer, token_of
from .train_config import eval_loads, shear_config

_CHECKPOINT = re.compile(r"ppo_(\d+)_steps\.zip$")


def checkpoints(run_dir: Path, token: str | None = None) -> list[tuple[int, Path, Path]]:
    """Every complete checkpoint (model and statistics both present; with ``token``, only those it stamped),
    newest first."""
    found = []
    for path in (run_dir / "checkpoints").glob("ppo_*_steps.zip"):
        match = _CHECKPOINT.search(path.name)
        stats = path.with_name(f"ppo_vecnormalize_{match.group(1)}_steps.npz") if match else None
        if match and stats.exists() and (token is None or token_of(stats) == token):
            found.append((int(match.group(1)), path, stats))
    return sorted(found, reverse=True)


def latest_checkpoint(run_dir: Path) -> tuple[int, Path, Path] | None:
    found = checkpoints(run_dir)
    return found[0] if found else None


def _checkpoint_callback(save_freq: int, save_path: Path, token: str = "") -> Any:
    """SB3's CheckpointCallback (model + VecNormalize statistics every ``save_freq`` calls), writing each file
    atomically (the statistics as ``.npz``, stamped with the step count and ``token``)."""
    from stable_baselines3.common.callbacks import CheckpointCallback

    class AtomicCheckpoint(CheckpointCallback):
        def _on_step(self) -> bool:
            if self.n_calls % self.save_freq == 0:
                Path(self.save_path).mkdir(parents=True, exist_ok=True)
                write_atomic(self._checkpoint_path(extension="zip"), lambda p: self.model.save(str(p)))
                save_normalizer(self._checkpoint_path("vecnormalize_", extension="npz"),
                                self.model.get_vec_normalize_env(), self.num_timesteps, token)
            return True

    return AtomicCheckpoint(save_freq=save_freq, save_path=str(save_path), name_prefix="ppo", save_vecnormalize=True)


def _mimicry_callback(config: dict[str, Any], curve_path: Path, wall: Any) -> Any:
    """Callback run after each evaluation: the deterministic policy's mimicry error at every evaluation load."""
    from stable_baselines3.common.callbacks import BaseCallback

    from .evaluation import evaluate
    from .ppo_controller import PPOController
    loads = eval_loads(config)
    env_kwargs = config.get("env", {})

    class MimicryCurve(BaseCallback):
        def _on_step(self) -> bool:
            controller = PPOController(self.model, self.model.get_vec_normalize_env())
            results = [evaluate(controller, f, env_kwargs=env_kwargs) for f in loads]
            errors = [r.mimicry_error_mm for r in results]
            for f, r in zip(loads, results):
                self.logger.record(f"mimicry/error_mm_{f:g}N", r.mimicry_error_mm)
            self.logger.record("mimicry/mean_error_mm", float(np.mean(errors)))
            self.logger.record("mimicry/success_rate", float(np.mean([r.success for r in results])))
            new = not curve_path.exists()
            with open(curve_path, "a", newline="") as f:
                writer = csv.writer(f)
                if new:
                    writer.writerow(["timesteps", "wall_s"] + [f"error_mm_{f:g}N" for f in loads]
                                    + [f"reason_{f:g}N" for f in loads])
                writer.writerow([self.num_timesteps, f"{wall():.2f}"] + [f"{e:.4f}" for e in errors]
                                + [r.reason for r in results])
            return True

    return MimicryCurve()


def _wall_so_far(curve_path: Path) -> float:
    if not curve_path.exists():
        return 0.0
    with open(curve_path) as f:
        rows = list(csv.DictReader(f))
    return float(rows[-1]["wall_s"]) if rows else 0.0


def _truncate_curve(curve_path: Path, timesteps: int) -> None:
    """Drop the learning-curve rows written after the checkpoint a resumed run restarts from (they will be
    written again), so that a kill and resume leaves no duplicate row; a torn last line is dropped too."""
    if not curve_path.exists():
        return
    lines = curve_path.read_text().splitlines(keepends=True)
    header, kept = lines[:1], []
    for line in lines[1:]:
        first = line.split(",", 1)[0]
        if line.endswith("\n") and first.isdigit() and int(first) <= timesteps:
            kept.append(line)
    write_atomic(curve_path, lambda p: p.write_text("".join(header + kept)))


class LoadsRun:
    """One seed's v0 run under way: where it writes, how it resumes, evaluates and checkpoints (the trainer's
    ``layout`` interface: ``clear``, ``resume``, ``callbacks``, ``finish``)."""

    name = "ppo"

    def __init__(self, task: Any, config: dict[str, Any], train: dict[str, int], run_dir: Path):
        self.task, self.config, self.train, self.run_dir = task, config, train, run_dir
        self.curve_path = run_dir / "learning_curve.csv"
        self.tb_dir, self.tb_name = ((task.tensorboard_log, f"ppo_seed{task.seed}") if task.tensorboard_log
                                     else (str(run_dir / "tb"), "ppo"))
        self.wall_before, self.started = 0.0, time.perf_counter()
        self.model: Any = None

    @staticmethod
    def clear(run_dir: Path) -> None:
        """A run that does not resume: the previous run's checkpoints removed (a later resume must not pick them)."""
        for stale in (run_dir / "checkpoints").glob("ppo_*_steps.*"):
            stale.unlink()

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    def resume(self, venv: Any, algo_class: Any) -> Any:
        """The newest checkpoint that loads, as (model, its normalised env), or None (the curve then restarts)."""
        task = self.task
        for done, model_path, stats_path in checkpoints(self.run_dir, None if task.named else task.token):
            try:
                normalized = load_normalizer(stats_path, venv, timesteps=done)
                model = algo_class.load(str(model_path), env=normalized, device="cpu", tensorboard_log=self.tb_dir,
                                        verbose=task.verbose)
                if model.num_timesteps != done:
                    raise CheckpointError(f"the model is at step {model.num_timesteps}, its name says {done}")
            except Exception as err:  # a truncated or damaged file: fall back to the previous one
                print(f"warning: checkpoint {model_path.name} does not load ({type(err).__name__}: {err}); "
                      "trying the previous one", file=sys.stderr)
                continue
            _truncate_curve(self.curve_path, done)
            self.wall_before = _wall_so_far(self.curve_path)
            return model, normalized
        self.curve_path.unlink(missing_ok=True)
        return None

    def callbacks(self, model: Any) -> list[Any]:
        """The checkpoint saver and the evaluation at every ``eval_loads`` load (EvalCallback, then the curve)."""
        from stable_baselines3.common.callbacks import EvalCallback
        from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

        from .sb3_vec_env import ShearSB3VecEnv
        self.model, n_envs, loads = model, model.get_env().num_envs, eval_loads(self.config)
        norm = {k: v for k, v in (self.config.get("normalize") or {}).items() if k != "norm_reward"}
        evaluation = ShearSB3VecEnv(len(loads), shear_config(self.config), seed=self.task.seed + 10_000,
                                    row_options=[{"load_N": f} for f in loads])
        evaluation = VecNormalize(VecMonitor(evaluation), training=False, norm_reward=False, **norm)
        evaluator = EvalCallback(evaluation, n_eval_episodes=evaluation.num_envs,
                                 eval_freq=max(1, self.train["eval_freq"] // n_envs),
                                 best_model_save_path=str(self.run_dir / "eval"), log_path=str(self.run_dir / "eval"),
                                 deterministic=True, verbose=0,
                                 callback_after_eval=_mimicry_callback(self.config, self.curve_path, self.wall))
        saver = _checkpoint_callback(max(1, self.train["checkpoint_freq"] // n_envs), self.run_dir / "checkpoints",
                                     self.task.token)
        return [saver, evaluator]

    def finish(self) -> None:
        """Nothing beyond the trainer's common outputs (the curve is written at each evaluation)."""
