"""The actuator design study: ``triplanar study --out DIR`` (the command calls :func:`run_study`).

Trains PPO (``agents.trainer``; finished or interrupted runs are resumed, not redone), evaluates every
controller at the 12 load levels with :func:`agents.evaluation.evaluate`, and writes to DIR:

* ``episodes.csv``: one row per controller, load level and seed (mimicry error, outcome, travel, steps, ...);
* ``mimicry_table.csv``: mean mimicry error (mm) per controller and load level, PPO as mean and std over seeds;
* ``traces_<controller>.png``: overhead traces against the hydrostatic reference at every load level;
* ``errors_by_load.png``, ``actions_27.8N.png``, ``learning_curves.png``;
* ``summary.json``; and, only with ``--doc REPORT.md``, the Markdown report (see :mod:`experiments.report`;
  the repository's ``docs/actuator-study.md`` was written this way; an existing file is refused unless
  ``--overwrite-doc``).

The PPO runs in ``--ppo-dir`` are loaded with pickle and cloudpickle (``vecnormalize.pkl``, the SB3 zips): loading
such a file runs code, so use only runs you trained or that come from a trusted source.
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterable, Sequence

import numpy as np

from agents import EpisodeResult, LowFrictionTip, MomentMatching, SteelTip, TrackingTip, evaluate
from agents.train_config import PROFILES, V0, eval_loads, load_config
from agents.trainer import TrainResult, train_seeds
from triplanar import PAPER_LOADS_N
from triplanar.atomic import write_atomic
from triplanar.executor import ExecutorLike, run_tasks
from .study_result import StudyResult
from .tables import write_csv

PPO_NAME = "PPO"
DEFAULT_CONFIG = PROFILES[V0].configs["ppo"]


def scripted_controllers() -> list:
    """The four scripted controllers of the study, and the frictionless fixed tip (the paper's case B) as a
    reference for what removing the end friction alone achieves."""
    return [SteelTip(), LowFrictionTip(phi_deg=3.0), TrackingTip(), MomentMatching(),
            LowFrictionTip(phi_deg=0.0, name="frictionless tip")]


def read_curve(path: Path) -> dict[str, np.ndarray]:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    out = {key: np.array([float(r[key]) for r in rows]) for key in rows[0] if not key.startswith("reason")}
    out.update({key: np.array([r[key] for r in rows]) for key in rows[0] if key.startswith("reason")})
    return out


@dataclass(frozen=True)
class EvalTask:
    """One controller's evaluations at every load (an episode takes milliseconds: a task per episode would cost
    more in overhead than it computes): a scripted controller, or a PPO run as its (model, vecnormalize) paths."""

    controller: object
    loads: tuple[float, ...]
    seed: int
    env_kwargs: dict


@lru_cache(maxsize=8)
def _ppo_controller(model_path: str, vecnormalize_path: str):
    from agents.ppo_controller import PPOController
    return PPOController.load(model_path, vecnormalize_path, name=PPO_NAME)


def run_evaluation(task: EvalTask) -> list[EpisodeResult]:
    """:func:`agents.evaluate` at each of the task's loads, in order (a PPO policy is loaded once per process)."""
    controller = _ppo_controller(*task.controller) if isinstance(task.controller, tuple) else task.controller
    return [evaluate(controller, f, seed=task.seed, env_kwargs=task.env_kwargs) for f in task.loads]


def run_study(out_dir: str | Path, *, ppo_dir: str | Path = "runs/ppo", seeds: Sequence[int] = (0, 1, 2),
              config: str | Path = DEFAULT_CONFIG, timesteps: int | None = None, train: bool = True,
              loads: Iterable[float] = PAPER_LOADS_N, doc: str | Path | None = None,
              log: Callable[[str], None] = print, overwrite_doc: bool = False,
              executor: ExecutorLike = "serial") -> StudyResult:
    """Train (or resume) PPO for each seed, evaluate every controller at every load, write the outputs. The
    seeds, then the evaluations (controller x load x seed), are tasks on ``executor`` (:mod:`triplanar.executor`)."""

    from . import plots, report
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    loads = tuple(float(f) for f in loads)
    ppo_config = load_config(config, None, V0)
    if train and f"{loads[0]:g}" not in {f"{f:g}" for f in eval_loads(ppo_config)}:
        raise ValueError(f"{config}: eval_loads must include {loads[0]:g} N, the load of the learning-curve plot")
    eval_freq = int((ppo_config.get("train") or {}).get("eval_freq", 0))
    if train and timesteps is not None and timesteps < eval_freq:
        raise ValueError(f"--timesteps {timesteps}: fewer than {config}'s train.eval_freq = {eval_freq}, so no "
                         f"evaluation would run and the study has no learning curve to read; train at least "
                         f"{eval_freq} steps")
    if doc is not None and Path(doc).exists() and not overwrite_doc:
        raise ValueError(f"--doc {doc}: file exists; choose a new name or pass --overwrite-doc")
    env_kwargs = ppo_config.get("env", {})
    timings: dict[str, float] = {}
    runs: list[TrainResult] = []
    if train:
        started = time.perf_counter()
        log(f"PPO seeds {', '.join(map(str, seeds))}: training (or resuming) in {ppo_dir}")
        runs = [TrainResult.of(s) for s in train_seeds(ppo_dir, seeds, timesteps or 0, executor=executor,
                                                       progress=False, config=ppo_config, env_id=V0)]
        timings["ppo_training_this_call_s"] = time.perf_counter() - started
    for seed in seeds if not train else ():
        run_dir = Path(ppo_dir) / f"seed_{seed}"
        missing = [n for n in ("done.json", "final_model.zip", "vecnormalize.pkl") if not (run_dir / n).exists()]
        if missing:
            raise ValueError(f"--skip-train: {run_dir} is not a finished run (no {', '.join(missing)}); "
                             "train it first (without --skip-train)")
        info = json.loads((run_dir / "done.json").read_text())
        runs.append(TrainResult(run_dir, run_dir / "final_model.zip", run_dir / "vecnormalize.pkl",
                                run_dir / "learning_curve.csv", info["timesteps"], info["wall_s"]))
    started = time.perf_counter()
    tasks = [EvalTask(controller, loads, 0, env_kwargs) for controller in scripted_controllers()]
    tasks += [EvalTask((str(run.model_path), str(run.vecnormalize_path)), loads, seed, env_kwargs)
              for seed, run in zip(seeds, runs)]
    episodes: list[EpisodeResult] = [e for batch in run_tasks(run_evaluation, tasks, executor) for e in batch]
    timings["evaluation_s"] = time.perf_counter() - started
    result = StudyResult(out_dir, loads, episodes, runs,
                         {seed: read_curve(run.curve_path) for seed, run in zip(seeds, runs)}, timings)
    write_tables(result)
    plots.write_all(result)
    summary = report.summary(result)
    write_atomic(out_dir / "summary.json", lambda tmp: tmp.write_text(json.dumps(summary, indent=2)))
    if doc is not None:
        report.write_markdown(result, summary, Path(doc))
    log(f"study written to {out_dir}" + (f" and {doc}" if doc else ""))
    return result


def write_tables(result: StudyResult) -> None:
    write_csv(result.out_dir / "episodes.csv",
              ["controller", "load_N", "seed", "mimicry_error_mm", "reason", "travel_m", "steps", "duration_s",
               "return"],
              ([r.controller, r.load_N, r.seed, f"{r.mimicry_error_mm:.4f}", r.reason, f"{r.travel_m:.5f}", r.steps,
                f"{r.duration_s:.4f}", f"{r.episode_return:.4f}"] for r in result.episodes))
    names = [c for c in result.controllers if c != PPO_NAME]
    ppo = result.errors(PPO_NAME)
    write_csv(result.out_dir / "mimicry_table.csv",
              ["load_N"] + [f"{c} (mm)" for c in names] + ["PPO mean (mm)", "PPO std (mm)", "PPO seeds"],
              ([load] + [f"{result.errors(c)[0, j]:.3f}" for c in names]
               + [f"{ppo[:, j].mean():.3f}", f"{ppo[:, j].std():.3f}", ppo.shape[0]]
               for j, load in enumerate(result.loads)))
