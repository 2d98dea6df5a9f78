"""Robust PPO: trained on ``TriPlanarShear-v1`` (by default in bench mode under randomisation: unknown specimens),
with history either from a frame stack (``algo: ppo``: stable-baselines3's PPO on the batched v1's built-in stack,
flattened, as ``FlattenObservation(FrameStackObservation(env, 4))``: 60 inputs; the controller ``ppo_robust``) or from
a recurrent policy (``algo: recurrent``: sb3-contrib's ``RecurrentPPO`` with ``MlpLstmPolicy`` on the 15 bench
observations; the controller ``ppo_recurrent``).

Everything a run needs is an rl-zoo-style YAML file (``agents/robust.yaml``: the default bench, frame stack;
``agents/recurrent.yaml``: the LSTM): the env id and its arguments (any v1 argument, plus the batch's
``frame_stack``, ``start_bank``, ``bank_reuse``), ``n_envs`` (one batched env, :func:`agents.sb3_vec_env.bench_vec_env`),
``normalize`` (VecNormalize), ``policy``, ``hyperparams`` and ``train`` (steps, evaluation and checkpoint intervals,
torch threads). ``triplanar train --env TriPlanarShear-v1 --config agents/robust.yaml`` runs it.

``train_seeds(out_dir, seeds, timesteps, executor=...)`` trains one run per seed through the project's executor
(:func:`triplanar.workbench.executor.run_tasks`; a finished seed is read back, not trained again). Each run writes
``OUT/seed_S/``: ``config.json`` (the configuration it ran), ``final_model.zip`` and ``vecnormalize.pkl`` (temporary
name, then rename), ``learning_curve.csv`` (at every evaluation, every ``train.eval_freq`` steps, by default
``EVALUATIONS`` points over the run: timesteps, wall seconds, and on ``CURVE_BENCHES`` tuning benches, never the
held-out ones, the success rate, mimicry error over successful episodes and the score of :mod:`agents.heldout`) and
``done.json``. It reports through SB3's logger (:mod:`agents.train_logging`): ``verbose=1`` prints SB3's table,
``tensorboard_log`` names a TensorBoard folder (episode return, length, success, error, losses, evaluations). While it
trains, a run saves a checkpoint every ``checkpoint_freq`` steps (``OUT/seed_S/checkpoint/``: ``model_<N>.zip``, the
normalisation statistics ``vecnormalize_<N>.npz``, then ``state.json``, which names them, holds the learning curve so
far and is written last, so that a kill between files leaves the previous set in force); an interrupted run continues
from its last checkpoint (its remaining steps are then drawn from a generator seeded anew, so a resumed run is not
bitwise the run an uninterrupted one would have been). The SB3 zips are read by SB3 with cloudpickle, which can run
code: a checkpoint is resumed only in a run the caller named (``RobustTask.named``) or when it carries the task's
``token`` (written by this invocation), and ``final_model.zip`` and ``vecnormalize.pkl`` are for loading only runs you
trained.
"""

from __future__ import annotations

import csv
import json
import math
import pickle
import time
from collections import deque
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from triplanar.atomic import write_atomic
from triplanar.workbench.executor import ExecutorLike, TaskCheckpoint, run_tasks

from .checkpoint_files import CheckpointError, load_normalizer, save_normalizer
from .config_checks import check_hyperparams, check_n_envs, check_normalize
from .controller_base import Controller
from .ppo_controller import load_untrusted_sb3_zip, load_untrusted_vecnormalize
from .train_logging import episode_error_callback, record_evaluation

FRAMES = 4             # the frame stack of a run that does not say (runs from before config.json)
CURVE_BENCHES = 10
CHECKPOINT_FREQ = 50_000
EVALUATIONS = 20       # points of the learning curve when neither the YAML nor the caller sets train.eval_freq
ALGOS = {"ppo": "ppo_robust", "recurrent": "ppo_recurrent"}  # algo -> controller name in the tables
ROBUST_CONFIG = Path(__file__).with_name("robust.yaml")
RECURRENT_CONFIG = Path(__file__).with_name("recurrent.yaml")
DEFAULT_CONFIGS = {"ppo": ROBUST_CONFIG, "recurrent": RECURRENT_CONFIG}
ENV_ID = "TriPlanarShear-v1"
CONFIG_KEYS = ("env_id", "algo", "env", "n_envs", "normalize", "policy", "hyperparams", "train")
TRAIN_KEYS = ("total_timesteps", "eval_freq", "checkpoint_freq", "torch_threads")
BATCH_KEYS = ("frame_stack", "start_bank", "bank_reuse")   # the batched env's own arguments (envs.vector_v1)


def _positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"{where}: expected a positive integer, got {value!r}")
    return value


def load_robust_config(path: str | Path = ROBUST_CONFIG, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """The training YAML at ``path`` with ``overrides`` (``{"hyperparams.n_steps": 64}`` style), checked: a
    ValueError names the file and the key."""
    from triplanar.yaml_input import load_file
    config = load_file(path)
    if not isinstance(config, dict):
        raise ValueError(f"{path}: expected a mapping of keys ({', '.join(CONFIG_KEYS)}), got {type(config).__name__}")
    for key, value in (overrides or {}).items():
        node = config
        *parents, leaf = key.split(".")
        for parent in parents:
            node = node.setdefault(parent, {})
            if not isinstance(node, dict):
                raise ValueError(f"{path}: override {key}: {parent} is not a mapping")
        node[leaf] = value
    check_robust_config(config, str(path))
    return config


def check_robust_config(config: dict[str, Any], source: str = "config") -> None:
    """Refuse unknown keys and values that would fail only after training starts (ValueError naming the key)."""
    if config.get("env_id", ENV_ID) != ENV_ID:
        raise ValueError(f"{source}: env_id is {config['env_id']!r}: robust training runs {ENV_ID} (give --env "
                         f"{config['env_id']} to train on it; TriPlanarShear-v0 trains with agents/ppo.yaml)")
    for key in config:
        if key not in CONFIG_KEYS:
            raise ValueError(f"{source}: unknown key {key!r}; known keys: {', '.join(CONFIG_KEYS)}")
    if not isinstance(config.get("algo", "ppo"), str) or config.get("algo", "ppo") not in ALGOS:
        raise ValueError(f"{source}: algo: expected one of {', '.join(ALGOS)}, got {config['algo']!r}")
    for section in ("env", "normalize", "hyperparams", "train"):
        if not isinstance(config.get(section) or {}, dict):
            raise ValueError(f"{source}: {section}: expected a mapping, got {config[section]!r}")
    for key, value in (config.get("train") or {}).items():
        if key not in TRAIN_KEYS:
            raise ValueError(f"{source}: unknown key train.{key}; known keys: {', '.join(TRAIN_KEYS)}")
        _positive_int(value, f"{source}: train.{key}")
    if "n_envs" in config:
        check_n_envs(config["n_envs"], f"{source}: n_envs")
    check_hyperparams(config.get("hyperparams"), f"{source}: hyperparams")
    check_normalize(config.get("normalize"), f"{source}: normalize")
    policies = {"ppo": "MlpPolicy", "recurrent": "MlpLstmPolicy"}
    if "policy" in config and config["policy"] != policies[config.get("algo", "ppo")]:
        raise ValueError(f"{source}: policy: expected {policies[config.get('algo', 'ppo')]!r} for algo "
                         f"{config.get('algo', 'ppo')!r}, got {config['policy']!r:.80}")
    try:  # the env's own checks, on a batch of one (no specimen is drawn)
        make_vec_env({**config, "n_envs": 1}, seed=0, check_only=True)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{source}: env: {err}") from None


def make_vec_env(config: dict[str, Any], seed: int, check_only: bool = False) -> Any:
    """The training env of ``config``: ``n_envs`` batched v1 envs as one SB3 ``VecEnv``, env ``i`` seeded
    ``seed + i`` (``check_only``: the batch's arguments checked, no SB3 adapter built)."""
    from envs.core import ShearConfig, make_config
    from envs.triplanar_shear_v1 import BENCH_FIELDS, BenchConfig
    from envs.vector_v1 import BenchBatch
    env = dict(config.get("env") or {})
    known = {f.name for f in fields(ShearConfig)} | set(BENCH_FIELDS) | set(BATCH_KEYS)
    unknown = sorted(set(env) - known)
    if unknown:
        raise ValueError(f"unknown env argument(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    batch_kwargs = {k: env.pop(k) for k in BATCH_KEYS if k in env}
    bench = BenchConfig(**{k: env.pop(k) for k in BENCH_FIELDS if k in env})
    batch = BenchBatch(int(config.get("n_envs", 16)), make_config(None, **env), bench, **batch_kwargs)
    if check_only:
        return batch
    from .sb3_vec_env import ShearSB3VecEnv
    return ShearSB3VecEnv(batch.num_envs, seed=seed, batch=batch)


def frame_stack_of(config: dict[str, Any]) -> int:
    return int((config.get("env") or {}).get("frame_stack", 1))


def _algo_class(algo: str):
    if algo == "recurrent":
        from sb3_contrib import RecurrentPPO
        return RecurrentPPO
    from stable_baselines3 import PPO
    return PPO


class RobustPolicy(Controller):
    """A trained robust PPO as ``policy(obs) -> action`` on raw bench observations: keeps the frame stack itself
    (filled with the first observation of an episode, as ``FrameStackObservation`` pads)."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_robust", frames: int = FRAMES):
        self.model, self.normalizer, self.name, self.n_frames = model, normalizer, name, frames
        self.frames: deque = deque(maxlen=frames)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_robust") -> RobustPolicy:
        run_dir = Path(run_dir)  # UNPICKLES: a run the caller named (agents.ppo_controller's untrusted loaders)
        normalizer = load_untrusted_vecnormalize(run_dir / "vecnormalize.pkl")
        frames = frame_stack_of(run_config(run_dir)) if (run_dir / "config.json").exists() else FRAMES
        return cls(load_untrusted_sb3_zip(run_dir / "final_model.zip"), normalizer, name, frames)

    def reset(self, load_N: float, config: Any) -> None:
        self.frames.clear()

    def act(self, obs: np.ndarray) -> np.ndarray:
        if not self.frames:
            self.frames.extend([obs] * self.n_frames)
        else:
            self.frames.append(obs)
        stacked = np.concatenate(list(self.frames)).astype(np.float32)
        action, _ = self.model.predict(self.normalizer.normalize_obs(stacked), deterministic=True)
        return np.asarray(action, dtype=np.float32)


class RecurrentPolicy(Controller):
    """A trained recurrent PPO (``RecurrentPPO``) as ``policy(obs) -> action`` on raw bench observations: keeps the
    LSTM state itself, reset at each episode's start."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_recurrent"):
        self.model, self.normalizer, self.name = model, normalizer, name
        self.state: Any = None
        self.episode_start = np.ones((1,), dtype=bool)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_recurrent") -> RecurrentPolicy:
        run_dir = Path(run_dir)  # UNPICKLES: a run the caller named (agents.ppo_controller's untrusted loaders)
        normalizer = load_untrusted_vecnormalize(run_dir / "vecnormalize.pkl")
        return cls(load_untrusted_sb3_zip(run_dir / "final_model.zip", "recurrent"), normalizer, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.state = None
        self.episode_start = np.ones((1,), dtype=bool)

    def act(self, obs: np.ndarray) -> np.ndarray:
        normalized = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32)[None, :])
        action, self.state = self.model.predict(normalized, state=self.state, episode_start=self.episode_start,
                                                deterministic=True)
        self.episode_start = np.zeros((1,), dtype=bool)
        return np.asarray(action[0], dtype=np.float32)


def run_config(run_dir: str | Path) -> dict[str, Any]:
    """The configuration a run trained with (its ``config.json``)."""
    return json.loads((Path(run_dir) / "config.json").read_text())


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
    """One seed's run (module-level and picklable for the executor). ``config``: the YAML (default by ``algo``:
    ``agents/robust.yaml`` or ``agents/recurrent.yaml``); ``timesteps``, ``env_kwargs`` (env arguments),
    ``eval_freq``, ``checkpoint_freq`` and ``overrides`` (``(("hyperparams.n_steps", 64),)``) replace its values
    where given (0 or empty: the YAML's)."""

    out_dir: str
    seed: int
    timesteps: int = 0
    env_kwargs: tuple = ()
    eval_freq: int = 0
    algo: str = ""                         # "ppo" (frame stack), "recurrent" (RecurrentPPO, LSTM); "": the YAML's
    checkpoint_freq: int = 0
    config: str = ""
    overrides: tuple = ()
    progress: bool = False
    resume: bool = True                    # False: the seed's previous run (finished or not) is removed first
    token: str = ""                        # stamped on the checkpoints this task writes
    named: bool = True                     # the caller named out_dir: any checkpoint there resumes; else only token's
    verbose: int = 0                       # SB3's: 1 prints its table (episode return, success, error, losses)
    tensorboard_log: str = ""              # a folder for TensorBoard logs (SB3's tensorboard_log); "": none

    def resolved(self) -> dict[str, Any]:
        """The run's configuration: the YAML with this task's values in it (checked)."""
        path = self.config or DEFAULT_CONFIGS.get(self.algo or "ppo")
        if path is None:
            raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {self.algo!r}")
        overrides = dict(self.overrides)
        overrides.update({f"env.{k}": v for k, v in self.env_kwargs})
        for key, value in (("train.total_timesteps", self.timesteps), ("train.eval_freq", self.eval_freq),
                           ("train.checkpoint_freq", self.checkpoint_freq)):
            if value:
                overrides[key] = int(value)
        config = load_robust_config(path, overrides)
        if self.algo and config.get("algo", "ppo") != self.algo:
            raise ValueError(f"{path}: algo is {config.get('algo', 'ppo')!r}, the task asks for {self.algo!r}")
        return config


def _new_model(config: dict[str, Any], venv: Any, task: RobustTask) -> Any:
    algo = config.get("algo", "ppo")
    default_policy = "MlpLstmPolicy" if algo == "recurrent" else "MlpPolicy"
    return _algo_class(algo)(config.get("policy", default_policy), venv, seed=task.seed, device="cpu",
                             verbose=task.verbose, tensorboard_log=task.tensorboard_log or None,
                             **(config.get("hyperparams") or {}))


def _refuse_another_configuration(run_dir: Path, config: dict[str, Any]) -> None:
    """A run directory continues only the run it holds: what it trained (``config.json``) must match ``config`` but
    for the step budget and the evaluation and checkpoint intervals."""
    path = run_dir / "config.json"
    if not path.exists() or not ((run_dir / "checkpoint" / "state.json").exists() or (run_dir / "done.json").exists()):
        return  # nothing to continue: a failed start's config.json does not bind the next run
    before = json.loads(path.read_text())
    now = json.loads(json.dumps(config))   # as JSON keeps it (tuples become lists)
    for key in CONFIG_KEYS:
        if key != "train" and before.get(key) != now.get(key):
            raise ValueError(f"{run_dir} holds a run trained with another {key} ({before.get(key)!r}, now "
                             f"{now.get(key)!r}): give another --out, or --no-resume to replace it")


def _prepare_run_dir(task: RobustTask, config: dict[str, Any]) -> Path:
    """The seed's run directory: created, emptied of a previous run unless the task resumes, refused if it holds a
    run of another configuration."""
    run_dir = Path(task.out_dir) / f"seed_{task.seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    if not task.resume:
        import shutil
        for name in ("done.json", "final_model.zip", "vecnormalize.pkl", "learning_curve.csv"):
            (run_dir / name).unlink(missing_ok=True)
        shutil.rmtree(run_dir / "checkpoint", ignore_errors=True)
    _refuse_another_configuration(run_dir, config)
    return run_dir


@dataclass
class _SeedRun:
    """One seed's training under way: the model, its normalised env, the learning curve so far, and what the
    curve's evaluations and the checkpoints need."""

    algo: str
    frames: int
    model: Any
    venv: Any
    rows: list[dict[str, float]]
    wall_before: float          # wall seconds spent before the checkpoint this run resumes from
    ckpt: Path
    env_kwargs: dict[str, Any]  # the single env's arguments (evaluation episodes)
    curve_benches: list[Any]
    started: float = 0.0

    def wall(self) -> float:
        return self.wall_before + time.perf_counter() - self.started

    def evaluate(self) -> None:
        """One point of the learning curve: the policy on the tuning benches."""
        from .heldout import summarise

        if self.algo == "recurrent":
            policy = RecurrentPolicy(self.model, self.venv)
        else:
            policy = RobustPolicy(self.model, self.venv, frames=self.frames)
        stats = summarise(evaluate_policy_on(policy, self.curve_benches, self.env_kwargs, "tuning"))
        record_evaluation(self.model, stats)
        self.rows.append({"timesteps": self.model.num_timesteps, "wall_s": self.wall(), **stats})

    def checkpoint(self, token: str = "") -> None:
        """The model and its statistics under names carrying the step count, then ``state.json`` naming them
        (the set's commit), then the previous set removed."""
        self.ckpt.mkdir(exist_ok=True)
        steps = int(self.model.num_timesteps)
        model, stats = f"model_{steps}.zip", f"vecnormalize_{steps}.npz"
        write_atomic(self.ckpt / model, lambda p: self.model.save(str(p)))
        save_normalizer(self.ckpt / stats, self.venv, steps, token)
        state = {"timesteps": steps, "wall_s": self.wall(), "curve": self.rows, "model": model,
                 "vecnormalize": stats, "token": token}
        write_atomic(self.ckpt / "state.json", lambda p: p.write_text(json.dumps(state)))
        for old in self.ckpt.iterdir():
            if old.name not in (model, stats, "state.json") and not old.name.startswith("."):
                old.unlink(missing_ok=True)


def _read_checkpoint_state(task: RobustTask, ckpt: Path) -> dict[str, Any]:
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


def _start_or_resume(task: RobustTask, config: dict[str, Any], run_dir: Path) -> _SeedRun:
    """A new model on a new normalised env, or the run's checkpoint (model, normalisation statistics, curve and
    wall time so far) when there is one."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from .heldout import TUNING_SEED, random_benches

    algo = config.get("algo", "ppo")
    # the single env's arguments (evaluation episodes): the batch's own keys left out
    env_kwargs = {k: v for k, v in (config.get("env") or {}).items() if k not in BATCH_KEYS}
    venv_raw = VecMonitor(make_vec_env(config, task.seed))   # episode return and length for SB3's logger
    ckpt = run_dir / "checkpoint"
    rows: list[dict[str, float]] = []
    wall_before = 0.0
    if (ckpt / "state.json").exists():
        state = _read_checkpoint_state(task, ckpt)
        rows, wall_before = state["curve"], state["wall_s"]
        venv_raw.seed(task.seed + 7919 * state["timesteps"])   # a fresh stream for the remaining steps
        venv = load_normalizer(ckpt / state["vecnormalize"], venv_raw, timesteps=state["timesteps"])
        model = _algo_class(algo).load(str(ckpt / state["model"]), env=venv, device="cpu", verbose=task.verbose,
                                       tensorboard_log=task.tensorboard_log or None)
        if model.num_timesteps != state["timesteps"]:
            raise CheckpointError(f"{ckpt / state['model']}: a model at step {model.num_timesteps}, state.json says "
                                  f"{state['timesteps']}")
    else:
        norm = {"norm_obs": True, "norm_reward": True, "clip_obs": 10.0, "gamma": 0.99, **(config.get("normalize") or {})}
        venv = VecNormalize(venv_raw, **norm)
        model = _new_model(config, venv, task)
    curve_benches = random_benches(CURVE_BENCHES, TUNING_SEED + 1, env_kwargs)
    return _SeedRun(algo, frame_stack_of(config), model, venv, rows, wall_before, ckpt, env_kwargs, curve_benches,
                    started=time.perf_counter())


def default_eval_freq(config: dict[str, Any], timesteps: int) -> int:
    """Steps between the learning curve's evaluations when nobody set them: ``EVALUATIONS`` points over the run, at
    least one rollout (``n_envs * n_steps``) apart."""
    rollout = int(config.get("n_envs", 16)) * int((config.get("hyperparams") or {}).get("n_steps", 2048))
    return max(rollout, timesteps // EVALUATIONS)


def _curve_callback(run: _SeedRun, timesteps: int, eval_freq: int, checkpoint_freq: int, token: str = "") -> Any:
    """The SB3 callback that evaluates the run every ``eval_freq`` steps (the learning curve) and checkpoints it every
    ``checkpoint_freq`` steps, neither at the end (the run's end does both its own way)."""
    from stable_baselines3.common.callbacks import BaseCallback

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
                run.checkpoint(token)

    return Curve()


def _write_results(run: _SeedRun, task: RobustTask, run_dir: Path) -> dict[str, Any]:
    """The finished run's files (learning curve, model, normalisation statistics, then ``done.json``, each written
    whole); returns its summary."""
    rows = run.rows

    def write_curve(path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    write_atomic(run_dir / "learning_curve.csv", write_curve)
    write_atomic(run_dir / "final_model.zip", lambda p: run.model.save(str(p)))
    run.venv.venv = None  # the statistics only (as agents.train_ppo saves them)

    def dump(p: Path) -> None:
        with open(p, "wb") as f:
            pickle.dump(run.venv, f)

    write_atomic(run_dir / "vecnormalize.pkl", dump)
    summary = {"seed": task.seed, "algo": run.algo, "timesteps": int(run.model.num_timesteps), "wall_s": run.wall(),
               "run_dir": str(run_dir)}
    write_atomic(run_dir / "done.json", lambda p: p.write_text(json.dumps(summary)))
    return summary


def train_robust(task: RobustTask) -> dict[str, Any]:
    """Train one seed (module-level and picklable for the executor); returns its summary. Resumes from the run's
    checkpoint if there is one."""
    import torch

    config = task.resolved()
    train = {"total_timesteps": 100_000, "checkpoint_freq": CHECKPOINT_FREQ, "torch_threads": 1,
             **(config.get("train") or {})}
    timesteps = train["total_timesteps"]
    train.setdefault("eval_freq", default_eval_freq(config, timesteps))
    torch.set_num_threads(int(train["torch_threads"]))
    run_dir = _prepare_run_dir(task, config)
    done = run_dir / "done.json"
    if done.exists():
        return json.loads(done.read_text())
    write_atomic(run_dir / "config.json", lambda p: p.write_text(json.dumps(config, indent=2)))
    run = _start_or_resume(task, config, run_dir)
    remaining = timesteps - run.model.num_timesteps
    if remaining > 0:
        callbacks = [_curve_callback(run, timesteps, train["eval_freq"], train["checkpoint_freq"], task.token),
                     episode_error_callback()]
        if task.progress:
            from .progress import progress_callback
            callbacks.append(progress_callback(timesteps, f"{ALGOS[run.algo]} seed {task.seed}"))
        run.model.learn(total_timesteps=remaining, callback=callbacks,
                        tb_log_name=f"{ALGOS[run.algo]}_seed{task.seed}",
                        reset_num_timesteps=run.model.num_timesteps == 0)
    run.evaluate()
    return _write_results(run, task, run_dir)


def seed_tasks(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 0, *,
               env_kwargs: dict[str, Any] | None = None, eval_freq: int = 0, algo: str = "",
               checkpoint_freq: int = 0, config: str | Path = "", overrides: dict[str, Any] | None = None,
               progress: bool = False, resume: bool = True, token: str = "", named: bool = True, verbose: int = 0,
               tensorboard_log: str | Path = "") -> list[RobustTask]:
    """The tasks of :func:`train_seeds` (one per seed), for callers that run several kinds in one executor call;
    0 or empty values take the YAML's (``config``, default by ``algo``). The configuration is checked here, before
    any task runs."""
    if timesteps < 0 or not math.isfinite(timesteps):
        raise ValueError(f"timesteps must be positive, got {timesteps}")
    if algo and algo not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {algo!r}")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    tasks = [RobustTask(str(out_dir), int(s), int(timesteps), tuple(sorted((env_kwargs or {}).items())), eval_freq,
                        algo, checkpoint_freq, str(config), tuple(sorted((overrides or {}).items())), progress,
                        resume, token, named, verbose, str(tensorboard_log or ""))
             for s in seeds]
    if tasks:  # checked now, and each task names its algorithm (callers sort the runs by it)
        resolved_algo = tasks[0].resolved().get("algo", "ppo")
        tasks = [replace(task, algo=resolved_algo) for task in tasks]
    return tasks


def train_seeds(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 0, *,
                env_kwargs: dict[str, Any] | None = None, executor: ExecutorLike = None,
                eval_freq: int = 0, algo: str = "", config: str | Path = "",
                overrides: dict[str, Any] | None = None, progress: bool = True,
                resume: bool = True, token: str = "", named: bool = True, verbose: int = 0,
                tensorboard_log: str | Path = "") -> list[dict[str, Any]]:
    """One robust PPO run per seed (``algo``: ``"ppo"`` frame stack, ``"recurrent"`` LSTM; or ``config``, a YAML),
    through the project's executor (resumable per seed, and inside a seed from its last checkpoint)."""
    tasks = seed_tasks(out_dir, seeds, timesteps, env_kwargs=env_kwargs, eval_freq=eval_freq, algo=algo,
                       config=config, overrides=overrides, progress=progress, resume=resume, token=token,
                       named=named, verbose=verbose, tensorboard_log=tensorboard_log)
    name = ALGOS[tasks[0].resolved().get("algo", "ppo")] if tasks else "robust"
    return run_tasks(train_robust, tasks, executor=executor, progress=progress, desc=f"{name} seeds",
                     checkpoint=TaskCheckpoint(Path(out_dir) / "tasks") if resume else None)
