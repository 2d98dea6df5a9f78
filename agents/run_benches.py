"""The run folder of a ``TriPlanarShear-v1`` training (layout ``benches``, :mod:`agents.train_config`): evaluations on
tuning benches and one checkpoint set. ``OUT/seed_S`` holds:

* ``checkpoint/``: every ``checkpoint_freq`` steps, ``model_<N>.zip``, the normalisation statistics
  ``vecnormalize_<N>.npz``, then ``state.json``, which names them, holds the learning curve so far and is written
  last, so that a kill between files leaves the previous set in force. A resumed run continues from it, its
  remaining steps drawn from a generator seeded anew (``seed + 7919 * N``): it is not bitwise the run an
  uninterrupted one would have been. The set is resumed only in a run the caller named, or when it carries the
  task's ``token``;
* ``learning_curve.csv``: at every evaluation (every ``train.eval_freq`` steps, by default ``EVALUATIONS`` points
  over the run) and at the end: timesteps, wall seconds, and on ``CURVE_BENCHES`` tuning benches, never the held-out
  ones, the success rate, mimicry error over successful episodes and the score of :mod:`agents.heldout`;
* ``config.json``, ``final_model.zip``, ``vecnormalize.pkl`` and ``done.json`` (:mod:`agents.trainer`).
"""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import Any

from triplanar.atomic import write_atomic

from .checkpoint_files import CheckpointError, load_normalizer, save_normalizer
from .train_config import (ALGOS, deviation_estimator_of, estimator_state_of, extra_input_of, frame_stack_of,
                           single_env_kwargs)
from .train_logging import record_evaluation

CURVE_BENCHES = 10


def _read_state(task: Any, ckpt: Path) -> dict[str, Any]:
    """The checkpoint's ``state.json``, checked: a set this code wrote, and one the task may resume."""
    path = ckpt / "state.json"
    try:
        state = json.loads(path.read_text())
        model, stats, steps = state["model"], state["vecnormalize"], int(state["timesteps"])
    except (ValueError, KeyError, TypeError):
        raise CheckpointError(f"{path}: not a checkpoint this version can resume (give --no-resume to start "
                              "afresh)") from None
    if not task.named and state.get("token") != task.token:
        raise CheckpointError(f"{ckpt}: a checkpoint this command did not write (give --resume or --out to continue "
                              "it, --no-resume to replace it)")
    for name in (model, stats):
        if not isinstance(name, str) or "/" in name or name.startswith(".") or not (ckpt / name).is_file():
            raise CheckpointError(f"{path}: names {name!r}, which is not in {ckpt}")
    return {**state, "timesteps": steps}


class BenchesRun:
    """One seed's v1 run under way: the learning curve so far, where it writes, how it resumes, evaluates and
    checkpoints (the trainer's ``layout`` interface: ``clear``, ``resume``, ``callbacks``, ``finish``)."""

    def __init__(self, task: Any, config: dict[str, Any], train: dict[str, int], run_dir: Path):
        self.task, self.config, self.train, self.run_dir = task, config, train, run_dir
        self.algo = config.get("algo", "ppo")
        self.name = ALGOS[self.algo]
        self.tb_dir, self.tb_name = task.tensorboard_log or None, f"{self.name}_seed{task.seed}"
        self.ckpt = run_dir / "checkpoint"
        self.rows: list[dict[str, float]] = []
        self.wall_before, self.started = 0.0, time.perf_counter()
        self.model: Any = None
        self.curve_benches: list[Any] = []

    @staticmethod
    def clear(run_dir: Path) -> None:
        """A run that does not resume: the previous run's checkpoint removed."""
        import shutil
        shutil.rmtree(run_dir / "checkpoint", ignore_errors=True)

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    def resume(self, venv: Any, algo_class: Any) -> Any:
        """The checkpoint set, as (model, its normalised env), or None when there is none."""
        if not (self.ckpt / "state.json").exists():
            return None
        task = self.task
        state = _read_state(task, self.ckpt)
        self.rows, self.wall_before = state["curve"], state["wall_s"]
        venv.seed(task.seed + 7919 * state["timesteps"])   # a fresh stream for the remaining steps
        normalized = load_normalizer(self.ckpt / state["vecnormalize"], venv, timesteps=state["timesteps"])
        model = algo_class.load(str(self.ckpt / state["model"]), env=normalized, device="cpu", verbose=task.verbose,
                                tensorboard_log=self.tb_dir)
        if model.num_timesteps != state["timesteps"]:
            raise CheckpointError(f"{self.ckpt / state['model']}: a model at step {model.num_timesteps}, state.json "
                                  f"says {state['timesteps']}")
        return model, normalized

    def evaluate(self) -> None:
        """One point of the learning curve: the policy on the tuning benches."""
        from .heldout import summarise
        from .robust_policy import evaluate_policy_on, policy_of_model

        policy = policy_of_model(self.model, self.model.get_vec_normalize_env(), self.algo, frame_stack_of(self.config),
                                 extra_input_of(self.config))
        if deviation_estimator_of(self.config):   # trained on its estimator's output: judged on it, as it will drive
            from .deviation_estimator import DeviationEstimator
            from .estimated_policy import EstimatedDeviationPolicy
            policy = EstimatedDeviationPolicy(policy, DeviationEstimator.load(deviation_estimator_of(self.config)),
                                              with_state=estimator_state_of(self.config))
        stats = summarise(evaluate_policy_on(policy, self.curve_benches, single_env_kwargs(self.config), "tuning"))
        record_evaluation(self.model, stats)
        self.rows.append({"timesteps": self.model.num_timesteps, "wall_s": self.wall(), **stats})

    def checkpoint(self) -> None:
        """The model and its statistics under names carrying the step count, then ``state.json`` naming them
        (the set's commit), then the previous set removed."""
        self.ckpt.mkdir(exist_ok=True)
        steps, token = int(self.model.num_timesteps), self.task.token
        model, stats = f"model_{steps}.zip", f"vecnormalize_{steps}.npz"
        write_atomic(self.ckpt / model, lambda p: self.model.save(str(p)))
        save_normalizer(self.ckpt / stats, self.model.get_vec_normalize_env(), steps, token)
        state = {"timesteps": steps, "wall_s": self.wall(), "curve": self.rows, "model": model,
                 "vecnormalize": stats, "token": token}
        write_atomic(self.ckpt / "state.json", lambda p: p.write_text(json.dumps(state)))
        for old in self.ckpt.iterdir():
            if old.name not in (model, stats, "state.json") and not old.name.startswith("."):
                old.unlink(missing_ok=True)

    def callbacks(self, model: Any) -> list[Any]:
        """The SB3 callback that evaluates the run every ``eval_freq`` steps (the learning curve) and checkpoints it
        every ``checkpoint_freq`` steps, neither at the end (:meth:`finish` evaluates once more)."""
        from stable_baselines3.common.callbacks import BaseCallback

        from .heldout import TUNING_SEED, random_benches
        self.model = model
        self.curve_benches = random_benches(CURVE_BENCHES, TUNING_SEED + 1, single_env_kwargs(self.config))
        run, timesteps = self, self.train["total_timesteps"]
        eval_freq, checkpoint_freq = self.train["eval_freq"], self.train["checkpoint_freq"]

        class Curve(BaseCallback):
            def __init__(self) -> None:
                super().__init__()
                self.next_eval = (run.rows[-1]["timesteps"] + eval_freq) if run.rows else 0
                self.next_ckpt = run.model.num_timesteps + checkpoint_freq

            def _on_step(self) -> bool:
                if self.next_eval <= self.num_timesteps < timesteps:
                    self.next_eval += eval_freq
                    run.evaluate()
                return True

            def _on_rollout_end(self) -> None:
                if self.num_timesteps >= self.next_ckpt and self.num_timesteps < timesteps:
                    self.next_ckpt += checkpoint_freq
                    run.checkpoint()

        return [Curve()]

    def finish(self) -> None:
        """The last point of the curve, and the whole curve written."""
        self.evaluate()
        rows = self.rows

        def write_curve(path: Path) -> None:
            with open(path, "w", newline="") as f:
                writer = csv.DictWriter(f, fieldnames=list(rows[0]))
                writer.writeheader()
                writer.writerows(rows)

        write_atomic(self.run_dir / "learning_curve.csv", write_curve)
