"""Train PPO on TriPlanarShear-v0: ``triplanar train --out runs/ppo --seed 0`` (:mod:`agents.training`).

Hyperparameters come from a YAML file (default ``agents/ppo.yaml``). The run directory ``OUT/seed_S`` holds:

* ``checkpoints/ppo_<N>_steps.zip`` + ``ppo_vecnormalize_<N>_steps.npz``: resumable checkpoints, each written
  to a temporary name and renamed when complete (the statistics as plain arrays, :mod:`agents.checkpoint_files`). Running the same command again continues from the newest one
  that loads (a damaged one is skipped with a warning; ``--no-resume`` starts afresh and removes the previous
  run's checkpoints). Rows of ``learning_curve.csv`` written after the checkpoint resumed from are dropped, as
  they are written again;
* ``tb/``: TensorBoard logs (``tensorboard --logdir OUT``; or under ``tensorboard_log``, ``--tensorboard-log DIR``):
  SB3's ``rollout/*`` (episode return, length, success rate) and ``train/*`` (losses), ``rollout/error_mm_mean``
  (:mod:`agents.train_logging`) and ``mimicry/*`` from the evaluations;
* ``eval/``: EvalCallback's ``evaluations.npz`` and ``best_model.zip`` (highest mean return over the 12 loads);
* ``learning_curve.csv``: at every evaluation, timesteps, cumulative wall-clock seconds, and the deterministic
  policy's mimicry error (mm) and outcome at each evaluation load;
* ``final_model.zip`` + ``vecnormalize.pkl``: the policy at the end and its observation statistics;
  ``done.json`` marks a finished run (running again with at most its timesteps returns it untouched). All three
  are written completely or not at all (temporary name, then rename).

A resumed run continues the schedule and the logs; it is not bitwise identical to an uninterrupted run (the
generators' states are not checkpointed).

Resuming loads the checkpoint's SB3 zip, which SB3 reads with cloudpickle (it can run code): a run resumes only
from ``OUT/seed_S`` of a run the user named (``named``: ``--out`` or ``--resume``), or else only from checkpoints
carrying this invocation's ``token`` (a worker retried within the same command).
"""

from __future__ import annotations

import csv
import json
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from envs.triplanar_shear import ShearConfig, make_config
from triplanar import yaml_input
from triplanar.atomic import write_atomic
from triplanar.executor import ExecutorLike, run_tasks

from .checkpoint_files import CheckpointError, load_normalizer, save_normalizer, token_of
from .config_checks import check_hyperparams, check_n_envs, check_normalize
from .train_logging import episode_error_callback

DEFAULT_CONFIG = Path(__file__).with_name("ppo.yaml")
_CHECKPOINT = re.compile(r"ppo_(\d+)_steps\.zip$")


@dataclass(frozen=True)
class TrainResult:
    run_dir: Path
    model_path: Path
    vecnormalize_path: Path
    curve_path: Path
    timesteps: int
    wall_s: float


CONFIG_KEYS = ("env_id", "env", "n_envs", "normalize", "ppo", "train", "eval_loads")
ENV_ID = "TriPlanarShear-v0"
TRAIN_KEYS = ("total_timesteps", "eval_freq", "checkpoint_freq", "torch_threads")
NORMALIZE_KEYS = ("norm_obs", "norm_reward", "clip_obs", "clip_reward", "gamma", "epsilon", "norm_obs_keys")


def load_config(path: str | Path = DEFAULT_CONFIG, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """The hyperparameter YAML at ``path`` (with ``overrides``), checked: a ValueError names the file and key."""
    config = yaml_input.load_file(path)
    if config is None:
        config = {}
    if not isinstance(config, dict):
        raise ValueError(f"{path}: expected a mapping of keys ({', '.join(CONFIG_KEYS)}), got {type(config).__name__}")
    for key, value in (overrides or {}).items():  # "ppo.learning_rate": 1e-4 style
        node = config
        *parents, leaf = key.split(".")
        for parent in parents:
            node = node.setdefault(parent, {})
            if not isinstance(node, dict):
                raise ValueError(f"{path}: override {key}: {parent} is not a mapping")
        node[leaf] = value
    check_config(config, str(path))
    return config


def _positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"{where}: expected a positive integer, got {value!r}")
    return value


def check_config(config: dict[str, Any], source: str = "config") -> None:
    """Refuse unknown keys and values that would fail only after training (ValueError naming the key)."""
    if config.get("env_id", ENV_ID) != ENV_ID:
        raise ValueError(f"{source}: env_id is {config['env_id']!r}: this trainer runs {ENV_ID} (give --env "
                         f"{config['env_id']} to train on it)")
    for key in config:
        if key not in CONFIG_KEYS:
            raise ValueError(f"{source}: unknown key {key!r}; known keys: {', '.join(CONFIG_KEYS)}")
    for section, known in (("train", TRAIN_KEYS), ("normalize", NORMALIZE_KEYS)):
        node = config.get(section, {}) or {}
        if not isinstance(node, dict):
            raise ValueError(f"{source}: {section}: expected a mapping, got {node!r}")
        for key in node:
            if key not in known:
                raise ValueError(f"{source}: unknown key {section}.{key}; known keys: {', '.join(known)}")
    for key in TRAIN_KEYS:
        if key in (config.get("train") or {}):
            _positive_int(config["train"][key], f"{source}: train.{key}")
    if "n_envs" in config:
        check_n_envs(config["n_envs"], f"{source}: n_envs")
    check_hyperparams(config.get("ppo"), f"{source}: ppo", extra=("policy",))
    check_normalize(config.get("normalize"), f"{source}: normalize")
    for section in ("env", "ppo"):
        if not isinstance(config.get(section, {}) or {}, dict):
            raise ValueError(f"{source}: {section}: expected a mapping, got {config[section]!r}")
    try:
        env_config(config)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{source}: env: {err}") from None
    if "eval_loads" in config:
        loads = config["eval_loads"]
        if not isinstance(loads, list) or not loads or any(
                isinstance(f, bool) or not isinstance(f, (int, float)) or not np.isfinite(f) or f <= 0 for f in loads):
            raise ValueError(f"{source}: eval_loads: expected a non-empty list of positive loads in N, got {loads!r}")


def env_config(config: dict[str, Any]) -> ShearConfig:
    return make_config(ShearConfig(), **config.get("env", {}))


def eval_loads(config: dict[str, Any]) -> list[float]:
    return [float(f) for f in config.get("eval_loads", env_config(config).load_levels)]


def make_vec_envs(config: dict[str, Any], seed: int):
    """(training VecNormalize env, evaluation VecNormalize env: one env per evaluation load)."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from .sb3_vec_env import ShearSB3VecEnv
    shear = env_config(config)
    norm = config.get("normalize", {})
    train = VecNormalize(VecMonitor(ShearSB3VecEnv(int(config.get("n_envs", 16)), shear, seed=seed)), **norm)
    loads = eval_loads(config)
    evaluation = ShearSB3VecEnv(len(loads), shear, seed=seed + 10_000, row_options=[{"load_N": f} for f in loads])
    evaluation = VecNormalize(VecMonitor(evaluation), training=False, norm_reward=False,
                              **{k: v for k, v in norm.items() if k not in ("norm_reward",)})
    return train, evaluation


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


def _checkpoint_callback(save_freq: int, save_path: Path, token: str = ""):
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


def _mimicry_callback(config: dict[str, Any], curve_path: Path, wall_offset: float, started: float):
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
            wall = wall_offset + time.perf_counter() - started
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
                writer.writerow([self.num_timesteps, f"{wall:.2f}"] + [f"{e:.4f}" for e in errors]
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


def train_ppo(config: str | Path | dict[str, Any] = DEFAULT_CONFIG, out_dir: str | Path = "runs/ppo", seed: int = 0,
              total_timesteps: int | None = None, resume: bool = True, callbacks: Sequence[Any] = (),
              verbose: int = 0, progress: bool = False, token: str = "", named: bool = True,
              tensorboard_log: str | Path = "") -> TrainResult:
    """Train (or resume) one PPO run; see the module docstring for what it writes. ``named``: the caller named
    ``out_dir`` (any checkpoint there may be resumed); otherwise only checkpoints stamped with ``token``.
    ``tensorboard_log``: a folder for the TensorBoard logs (the run's ``ppo_seed<S>_<N>`` in it; default the run
    directory's ``tb/``)."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import CallbackList, EvalCallback

    if isinstance(config, dict):
        check_config(config)
    else:
        config = load_config(config)
    train_cfg = config.get("train", {})
    torch.set_num_threads(int(train_cfg.get("torch_threads", 1)))
    total = int(total_timesteps if total_timesteps is not None else train_cfg.get("total_timesteps", 400_000))
    if total <= 0:
        raise ValueError(f"timesteps must be positive, got {total}")
    run_dir = Path(out_dir) / f"seed_{seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    tb_dir, tb_name = (str(tensorboard_log), f"ppo_seed{seed}") if tensorboard_log else (str(run_dir / "tb"), "ppo")
    curve_path = run_dir / "learning_curve.csv"
    model_path, stats_path, done_path = run_dir / "final_model.zip", run_dir / "vecnormalize.pkl", run_dir / "done.json"
    if resume and done_path.exists():
        finished = json.loads(done_path.read_text())
        if finished["timesteps"] >= total and model_path.exists() and stats_path.exists():
            return TrainResult(run_dir, model_path, stats_path, curve_path, finished["timesteps"], finished["wall_s"])
    done_path.unlink(missing_ok=True)
    train_env, eval_env = make_vec_envs(config, seed)
    checkpoint, model = None, None
    for candidate in (checkpoints(run_dir, None if named else token) if resume else []):
        done, checkpoint_model, checkpoint_stats = candidate  # the outputs stay final_model.zip, vecnormalize.pkl
        try:
            resumed_env = load_normalizer(checkpoint_stats, train_env.venv, timesteps=done)
            model = PPO.load(str(checkpoint_model), env=resumed_env, device="cpu", tensorboard_log=tb_dir,
                             verbose=verbose)
            if model.num_timesteps != done:
                raise CheckpointError(f"the model is at step {model.num_timesteps}, its name says {done}")
        except Exception as err:  # a truncated or damaged file: fall back to the previous one
            print(f"warning: checkpoint {checkpoint_model.name} does not load ({type(err).__name__}: {err}); "
                  "trying the previous one", file=sys.stderr)
            continue
        checkpoint, train_env = candidate, resumed_env
        _truncate_curve(curve_path, done)
        wall_offset = _wall_so_far(curve_path)
        break
    if checkpoint is None:
        if curve_path.exists():
            curve_path.unlink()
        if not resume:  # --no-resume replaces the previous run: a later resume must not pick its checkpoints
            for stale in (run_dir / "checkpoints").glob("ppo_*_steps.*"):
                stale.unlink()
        ppo = dict(config.get("ppo", {}))
        policy = ppo.pop("policy", "MlpPolicy")
        model = PPO(policy, train_env, seed=seed, device="cpu", verbose=verbose, tensorboard_log=tb_dir, **ppo)
        done, wall_offset = 0, 0.0
    n_envs = train_env.num_envs
    started = time.perf_counter()
    evaluation = EvalCallback(eval_env, n_eval_episodes=eval_env.num_envs,
                              eval_freq=max(1, int(train_cfg.get("eval_freq", 20_000)) // n_envs),
                              best_model_save_path=str(run_dir / "eval"), log_path=str(run_dir / "eval"),
                              deterministic=True, verbose=0,
                              callback_after_eval=_mimicry_callback(config, curve_path, wall_offset, started))
    saver = _checkpoint_callback(max(1, int(train_cfg.get("checkpoint_freq", 50_000)) // n_envs),
                                 run_dir / "checkpoints", token)
    remaining = max(0, total - done)
    if progress:
        from .progress import progress_callback
        callbacks = [*callbacks, progress_callback(total, f"PPO seed {seed}")]
    if remaining:
        model.learn(total_timesteps=remaining, callback=CallbackList([saver, evaluation, episode_error_callback(),
                                                                      *callbacks]),
                    reset_num_timesteps=checkpoint is None, tb_log_name=tb_name)
    write_atomic(model_path, lambda p: model.save(str(p)))
    write_atomic(stats_path, lambda p: model.get_vec_normalize_env().save(str(p)))
    wall = wall_offset + time.perf_counter() - started
    write_atomic(done_path, lambda p: p.write_text(json.dumps({"timesteps": int(model.num_timesteps), "wall_s": wall,
                                                                "seed": seed})))
    return TrainResult(run_dir, model_path, stats_path, curve_path, int(model.num_timesteps), wall)


@dataclass(frozen=True)
class SeedRun:
    """One seed's training, a task of :func:`train_seed_run` (runs on any executor: a pool, Ray)."""

    config: str | Path | dict[str, Any]
    out_dir: str | Path
    seed: int
    total_timesteps: int | None = None
    resume: bool = True
    verbose: int = 0
    progress: bool = False
    token: str = ""
    named: bool = True
    tensorboard_log: str = ""


def train_seed_run(run: SeedRun) -> TrainResult:
    return train_ppo(run.config, run.out_dir, run.seed, run.total_timesteps, resume=run.resume, verbose=run.verbose,
                     progress=run.progress, token=run.token, named=run.named, tensorboard_log=run.tensorboard_log)


def train_seeds(config: str | Path | dict[str, Any], out_dir: str | Path, seeds: Sequence[int],
                total_timesteps: int | None = None, resume: bool = True, verbose: int = 0,
                executor: ExecutorLike = "serial", progress: bool = False, token: str = "",
                named: bool = True, tensorboard_log: str | Path = "") -> list[TrainResult]:
    """:func:`train_ppo` for each seed (one task per seed, through ``executor``), results in seed order. A seed
    whose worker dies (Ray retries it) resumes from its own checkpoints in ``OUT/seed_S``."""
    tasks = [SeedRun(config, out_dir, int(seed), total_timesteps, resume, verbose, progress, token, named,
                     str(tensorboard_log or "")) for seed in seeds]
    return run_tasks(train_seed_run, tasks, executor, progress, desc="PPO seeds")
