"""The one trainer for both envs: PPO or recurrent PPO on ``TriPlanarShear-v0`` or ``-v1``, everything that differs in
the YAML (:mod:`agents.train_config`). ``triplanar train`` runs it; ``agents.train_ppo`` and ``agents.train_robust``
are older names for it.

``train_seeds(out_dir, seeds, config=..., executor=...)`` trains one run per seed through the project's executor
(a finished seed is read back, not trained again; an interrupted one continues from its last checkpoint). Each run
writes ``OUT/seed_S/``: ``config.json`` (the configuration it ran; a run folder continues only a run of the same
configuration but for ``train``), its checkpoints and learning curve (the layout of its env:
:mod:`agents.run_loads` for v0, :mod:`agents.run_benches` for v1), ``final_model.zip`` and ``vecnormalize.pkl``
(temporary name, then rename) and ``done.json`` last (running again with at most its timesteps returns it). It
reports through SB3's logger (:mod:`agents.train_logging`): ``verbose=1`` prints SB3's table, ``tensorboard_log``
names a TensorBoard folder. The SB3 zips are read by SB3 with cloudpickle, which can run code: a checkpoint is
resumed only in a run the caller named (``named``) or when it carries the task's ``token`` (written by this
invocation).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

from triplanar.atomic import write_atomic
from triplanar.executor import ExecutorLike, TaskCheckpoint, run_tasks

from .run_benches import BenchesRun
from .run_loads import LoadsRun
from .train_config import (ALGOS, CONFIG_KEYS, PROFILES, V0, algo_class, apply_overrides, check_config, env_id_of,
                           hyperparams_of, load_config, make_vec_env, policy_of, train_settings)
from .train_logging import episode_error_callback

LAYOUTS = {"loads": LoadsRun, "benches": BenchesRun}


@dataclass(frozen=True)
class TrainResult:
    """A finished run's files (a summary of :func:`train_run` read as paths)."""

    run_dir: Path
    model_path: Path
    vecnormalize_path: Path
    curve_path: Path
    timesteps: int
    wall_s: float

    @classmethod
    def of(cls, summary: dict[str, Any]) -> TrainResult:
        run_dir = Path(summary["run_dir"])
        return cls(run_dir, run_dir / "final_model.zip", run_dir / "vecnormalize.pkl", run_dir / "learning_curve.csv",
                   int(summary["timesteps"]), float(summary["wall_s"]))


@dataclass(frozen=True)
class TrainTask:
    """One seed's run (module-level and picklable for the executor). ``config``: a YAML path or a configuration
    (default: the env's YAML for ``algo``); ``env_id``: the env the caller trains ("": the configuration's, else
    v0); ``timesteps``, ``env_kwargs`` (env arguments), ``eval_freq``, ``checkpoint_freq`` and ``overrides``
    (``(("hyperparams.n_steps", 64),)``) replace its values where given (0 or empty: the YAML's)."""

    out_dir: str
    seed: int
    timesteps: int = 0
    env_kwargs: tuple = ()
    eval_freq: int = 0
    algo: str = ""                         # "ppo", "recurrent" (RecurrentPPO, LSTM); "": the YAML's
    checkpoint_freq: int = 0
    config: Any = ""
    overrides: tuple = ()
    progress: bool = False
    resume: bool = True                    # False: the seed's previous run (finished or not) is removed first
    token: str = ""                        # stamped on the checkpoints this task writes
    named: bool = True                     # the caller named out_dir: any checkpoint there resumes; else only token's
    verbose: int = 0                       # SB3's: 1 prints its table (episode return, success, error, losses)
    tensorboard_log: str = ""              # a folder for TensorBoard logs (SB3's tensorboard_log); "": the layout's
    env_id: str = ""

    def resolved(self) -> dict[str, Any]:
        """The run's configuration: the YAML with this task's values in it (checked)."""
        overrides = dict(self.overrides)
        overrides.update({f"env.{k}": v for k, v in self.env_kwargs})
        for key, value in (("train.total_timesteps", self.timesteps), ("train.eval_freq", self.eval_freq),
                           ("train.checkpoint_freq", self.checkpoint_freq)):
            if value:
                overrides[key] = int(value)
        env_id = self.env_id or None
        if isinstance(self.config, dict):
            source, config = "config", apply_overrides(json.loads(json.dumps(self.config)), overrides, "config")
            check_config(config, source, env_id)
        else:
            profile = PROFILES.get(env_id or V0)
            source = self.config or (profile.configs.get(self.algo or "ppo") if profile else None)
            if source is None:
                raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {self.algo!r}")
            config = load_config(source, overrides, env_id)
        if self.algo and config.get("algo", "ppo") != self.algo:
            raise ValueError(f"{source}: algo is {config.get('algo', 'ppo')!r}, the task asks for {self.algo!r}")
        return config


def _refuse_another_configuration(run_dir: Path, config: dict[str, Any]) -> None:
    """A run directory continues only the run it holds: what it trained (``config.json``) must match ``config`` but
    for ``train`` (the step budget and the evaluation and checkpoint intervals)."""
    path = run_dir / "config.json"
    if not path.exists() or not any((run_dir / p).exists() for p in ("checkpoint/state.json", "checkpoints",
                                                                      "done.json")):
        return  # nothing to continue: a failed start's config.json does not bind the next run
    before = json.loads(path.read_text())
    now = json.loads(json.dumps(config))   # as JSON keeps it (tuples become lists)
    for key in CONFIG_KEYS:
        if key != "train" and before.get(key) != now.get(key):
            raise ValueError(f"{run_dir} holds a run trained with another {key} ({before.get(key)!r}, now "
                             f"{now.get(key)!r}): give another --out, or --no-resume to replace it")


def _prepare_run_dir(task: TrainTask, config: dict[str, Any], layout: Any) -> Path:
    """The seed's run directory: created, emptied of a previous run unless the task resumes, refused if it holds a
    run of another configuration."""
    run_dir = Path(task.out_dir) / f"seed_{task.seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    if not task.resume:
        for name in ("done.json", "final_model.zip", "vecnormalize.pkl", "learning_curve.csv"):
            (run_dir / name).unlink(missing_ok=True)
        layout.clear(run_dir)
    _refuse_another_configuration(run_dir, config)
    return run_dir


def _finished(task: TrainTask, config: dict[str, Any], run_dir: Path, timesteps: int) -> dict[str, Any] | None:
    """The summary of a finished run of at least ``timesteps`` steps, else None."""
    done = run_dir / "done.json"
    if not (done.exists() and (run_dir / "final_model.zip").exists() and (run_dir / "vecnormalize.pkl").exists()):
        return None
    summary = json.loads(done.read_text())
    if summary["timesteps"] < timesteps:
        return None
    return {"seed": task.seed, "algo": config.get("algo", "ppo"), "run_dir": str(run_dir), **summary}


def _start_or_resume(task: TrainTask, config: dict[str, Any], run_dir: Path) -> Any:
    """The run under way (its layout's object, :data:`LAYOUTS`) with its model: a new one on a new normalised env,
    or the run's checkpoint when there is one."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    run = LAYOUTS[PROFILES[env_id_of(config)].layout](task, config, train_settings(config), run_dir)
    venv = VecMonitor(make_vec_env(config, task.seed))   # episode return and length for SB3's logger
    cls = algo_class(config.get("algo", "ppo"))
    resumed = run.resume(venv, cls)
    if resumed is not None:
        run.model = resumed[0]
        return run
    normalized = VecNormalize(venv, **(config.get("normalize") or {}))
    run.model = cls(policy_of(config), normalized, seed=task.seed, device="cpu", verbose=task.verbose,
                    tensorboard_log=run.tb_dir, **hyperparams_of(config))
    return run


def _write_results(run: Any, task: TrainTask, run_dir: Path) -> dict[str, Any]:
    """The finished run's files (the layout's, then model, normalisation statistics and ``done.json``, each written
    whole); returns its summary."""
    run.finish()
    model = run.model
    write_atomic(run_dir / "final_model.zip", lambda p: model.save(str(p)))
    write_atomic(run_dir / "vecnormalize.pkl", lambda p: model.get_vec_normalize_env().save(str(p)))
    summary = {"seed": task.seed, "algo": run.config.get("algo", "ppo"), "timesteps": int(model.num_timesteps),
               "wall_s": run.wall(), "run_dir": str(run_dir)}
    write_atomic(run_dir / "done.json", lambda p: p.write_text(json.dumps(summary)))
    return summary


def train_run(task: TrainTask) -> dict[str, Any]:
    """Train (or resume) one seed (module-level and picklable for the executor); returns its summary (seed, algo,
    timesteps, wall_s, run_dir)."""
    import time

    import torch

    config = task.resolved()
    train = train_settings(config)
    torch.set_num_threads(int(train["torch_threads"]))
    timesteps = train["total_timesteps"]
    run_dir = _prepare_run_dir(task, config, LAYOUTS[PROFILES[env_id_of(config)].layout])
    finished = _finished(task, config, run_dir, timesteps) if task.resume else None
    if finished is not None:
        return finished
    (run_dir / "done.json").unlink(missing_ok=True)
    write_atomic(run_dir / "config.json", lambda p: p.write_text(json.dumps(config, indent=2)))
    run = _start_or_resume(task, config, run_dir)
    resumed = run.model.num_timesteps > 0
    callbacks = [*run.callbacks(run.model), episode_error_callback()]
    if task.progress:
        from .progress import progress_callback
        callbacks.append(progress_callback(timesteps, f"{run.name} seed {task.seed}"))
    run.started = time.perf_counter()
    if timesteps > run.model.num_timesteps:
        from stable_baselines3.common.callbacks import CallbackList
        run.model.learn(total_timesteps=timesteps - run.model.num_timesteps, callback=CallbackList(callbacks),
                        reset_num_timesteps=not resumed, tb_log_name=run.tb_name)
    return _write_results(run, task, run_dir)


def seed_tasks(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 0, *,
               env_kwargs: dict[str, Any] | None = None, eval_freq: int = 0, algo: str = "",
               checkpoint_freq: int = 0, config: Any = "", overrides: dict[str, Any] | None = None,
               progress: bool = False, resume: bool = True, token: str = "", named: bool = True, verbose: int = 0,
               tensorboard_log: str | Path = "", env_id: str = "") -> list[TrainTask]:
    """The tasks of :func:`train_seeds` (one per seed), for callers that run several kinds in one executor call;
    0 or empty values take the YAML's (``config``, default by ``env_id`` and ``algo``). The configuration is checked
    here, before any task runs, and each task names its algorithm and env."""
    if timesteps is None:
        timesteps = 0
    if timesteps < 0 or not math.isfinite(timesteps):
        raise ValueError(f"timesteps must be positive, got {timesteps}")
    if algo and algo not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {algo!r}")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    config = config if isinstance(config, dict) else str(config)
    tasks = [TrainTask(str(out_dir), int(s), int(timesteps), tuple(sorted((env_kwargs or {}).items())), eval_freq,
                       algo, checkpoint_freq, config, tuple(sorted((overrides or {}).items())), progress,
                       resume, token, named, verbose, str(tensorboard_log or ""), env_id)
             for s in seeds]
    if tasks:
        resolved = tasks[0].resolved()
        tasks = [replace(task, algo=resolved.get("algo", "ppo"), env_id=env_id_of(resolved, env_id or None))
                 for task in tasks]
    return tasks


def train_seeds(out_dir: str | Path, seeds: Sequence[int] = (0, 1, 2), timesteps: int = 0, *,
                executor: ExecutorLike = None, progress: bool = True, **settings: Any) -> list[dict[str, Any]]:
    """One run per seed (``settings``: :func:`seed_tasks`'s: ``config``, ``env_id``, ``algo``, ``env_kwargs``,
    ``overrides``, ...) through the project's executor (resumable per seed, and inside a seed from its last
    checkpoint); summaries in seed order."""
    tasks = seed_tasks(out_dir, seeds, timesteps, progress=progress, **settings)
    name = ALGOS[tasks[0].algo] if tasks and tasks[0].env_id != V0 else "ppo"
    return run_tasks(train_run, tasks, executor=executor, progress=progress, desc=f"{name} seeds",
                     checkpoint=TaskCheckpoint(Path(out_dir) / "tasks") if settings.get("resume", True) else None)
