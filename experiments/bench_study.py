"""The bench study on ``TriPlanarShear-v1``: held-out evaluation and the actuator design sweep.

``python -m experiments.bench_study --out DIR [--ppo-timesteps N] [--recurrent-timesteps N] [--design-ppo-timesteps N]
[--seeds 0 1 2]`` (or ``triplanar study --bench --out DIR [--timesteps N] [--recurrent-timesteps N]
[--design-timesteps N] [--in-sample-run RUN]``). Steps, each resumable (every episode batch and every PPO seed is a task
of :func:`triplanar.workbench.executor.run_tasks` with a checkpoint directory under DIR/tasks):

1. tune the feedback and adaptive gains on ``TUNING_BENCHES`` tuning benches (never the held-out ones);
2. train robust PPO (:mod:`agents.train_robust`) on the default bench, one run per seed and kind: with a 4-frame stack
   (``ppo_robust``) and recurrent (``ppo_recurrent``, sb3-contrib's RecurrentPPO, an LSTM), all in one executor call;
3. evaluate every controller on the nominal bench (the paper's 12 loads, steel tip) and on the held-out benches
   -> ``heldout.csv``, ``heldout_episodes.csv`` (one row per episode), ``heldout.png``, ``robust_learning_curves.png``;
4. the design sweep: every design of :data:`DESIGNS`, its scripted controllers and a robust PPO of a shorter budget
   on the held-out benches -> ``designs.csv``, ``designs.png``, ``recommendation.txt``, ``bench_summary.json``.

All CSV/PNG/text outputs are written to a temporary name and renamed.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from agents.bench_controllers import make_controller
from agents.heldout import (TUNING_SEED, Outcome, heldout_benches, nominal_benches, random_benches, run_episode,
                            summarise, with_tip)
from triplanar.workbench.executor import ExecutorLike, TaskCheckpoint, run_tasks

N_HELDOUT = 50
TUNING_BENCHES = 20
TARGET_ERROR_MM = 1.0
TARGET_SUCCESS = 0.95
PI_GRID = [(kp, ki) for kp in (-20.0, -5.0, -1.0, 1.0, 5.0, 20.0, 50.0) for ki in (0.0, 50.0, 200.0)]
ADAPTIVE_GRID = (-5e5, -1e5, -2e4, 2e4, 1e5, 5e5)


@dataclass(frozen=True)
class Design:
    """Actuator hardware: tip friction, stage bandwidth, latency, rangefinder noise."""

    name: str
    tip_friction_deg: float
    stage_bandwidth_hz: float
    latency_s: float
    sensor_noise_m: float

    def env_kwargs(self) -> dict[str, Any]:
        return {"stage_bandwidth_hz": self.stage_bandwidth_hz, "latency_s": self.latency_s,
                "sensor_noise_m": self.sensor_noise_m}

    def demand(self) -> int:
        """Hardware demand, an ordinal sum (0 = least demanding): tip steel 0, PTFE 1, rolling 2; stage 5 Hz 0,
        20 Hz 1, 100 Hz 2, ideal 3; latency 10 ms 0, 0 ms 1; noise 1 mm 0, 0.2 mm 1, 0.05 mm 2."""
        tip = {8.0: 0, 3.0: 1, 0.5: 2}[self.tip_friction_deg]
        stage = {5.0: 0, 20.0: 1, 100.0: 2}.get(self.stage_bandwidth_hz, 3)
        latency = 0 if self.latency_s > 0 else 1
        noise = {1e-3: 0, 2e-4: 1, 5e-5: 2}[self.sensor_noise_m]
        return tip + stage + latency + noise


DESIGNS = (
    Design("steel_slow_noisy", 8.0, 5.0, 0.01, 1e-3),
    Design("steel_lab", 8.0, 20.0, 0.01, 2e-4),
    Design("steel_ideal", 8.0, math.inf, 0.0, 5e-5),
    Design("ptfe_slow", 3.0, 5.0, 0.01, 2e-4),
    Design("ptfe_lab", 3.0, 20.0, 0.01, 2e-4),
    Design("ptfe_lab_noisy", 3.0, 20.0, 0.01, 1e-3),
    Design("ptfe_fast", 3.0, 100.0, 0.0, 2e-4),
    Design("ptfe_ideal", 3.0, math.inf, 0.0, 5e-5),
    Design("rolling_slow_noisy", 0.5, 5.0, 0.01, 1e-3),
    Design("rolling_slow", 0.5, 5.0, 0.01, 2e-4),
    Design("rolling_lab", 0.5, 20.0, 0.01, 2e-4),
    Design("rolling_lab_precise", 0.5, 20.0, 0.01, 5e-5),
    Design("rolling_fast", 0.5, 100.0, 0.0, 2e-4),
    Design("rolling_ideal", 0.5, math.inf, 0.0, 5e-5),
)


# -- tasks (module level, picklable) ---------------------------------------------------------------

@dataclass(frozen=True)
class EpisodeBatch:
    """One controller on a list of benches under one bench configuration."""

    label: str                       # the name written to the tables
    controller: str                  # agents.bench_controllers name, or "ppo:<run_dir>" (frame stack),
    #                                  "ppo_recurrent:<run_dir>" (LSTM) or "ppo_state:<run_dir>" (v0, exact state)
    params: tuple = ()
    bench_set: str = "heldout"       # heldout, nominal or tuning
    n: int = N_HELDOUT
    tip_friction_deg: float | None = None
    env_kwargs: tuple = ()


def _benches(batch: EpisodeBatch):
    if batch.bench_set == "nominal":
        return nominal_benches()
    if batch.bench_set == "tuning":
        return random_benches(batch.n, TUNING_SEED)
    return heldout_benches(batch.n)


def run_batch(batch: EpisodeBatch) -> list[Outcome]:
    env_kwargs = dict(batch.env_kwargs)
    benches = [with_tip(b, batch.tip_friction_deg) for b in _benches(batch)]
    if batch.controller.startswith("ppo:"):
        from agents.train_robust import load_policy
        controller: Any = load_policy(batch.controller[4:], "ppo", name=batch.label)
    elif batch.controller.startswith("ppo_recurrent:"):
        from agents.train_robust import load_policy
        controller = load_policy(batch.controller[len("ppo_recurrent:"):], "recurrent", name=batch.label)
    elif batch.controller.startswith("ppo_state:"):
        from agents.ppo_controller import PPOController
        run = Path(batch.controller[len("ppo_state:"):])
        ppo = PPOController.load(run / "final_model.zip", run / "vecnormalize.pkl", name=batch.label)
        controller = _Named(batch.label, ppo.act)
        env_kwargs["observation_mode"] = "state"
    else:
        controller = make_controller(batch.controller, **dict(batch.params))
        controller.name = batch.label
    return [run_episode(controller, b, env_kwargs=env_kwargs, seed=i, bench_set=batch.bench_set, index=i)
            for i, b in enumerate(benches)]


@dataclass
class _Named:
    name: str
    act: Any

    def reset(self, load_N: float, config: Any) -> None:
        pass


# -- the study ------------------------------------------------------------------------------------

def _write_atomic(path: Path, write) -> None:
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def _csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            writer.writerows(rows)
    _write_atomic(path, write)


def tune(out_dir: Path, executor: ExecutorLike) -> tuple[dict[str, float], dict[str, float], list[list[Any]]]:
    """Grid search of the PI gains and the adaptive gain on the tuning benches (default bench, drawn tips); the
    lowest score wins (ties: the first in the grid)."""
    batches = [EpisodeBatch(f"pi kp={kp:g} ki={ki:g}", "pi_feedback", (("kp", kp), ("ki", ki)), "tuning",
                            TUNING_BENCHES) for kp, ki in PI_GRID]
    batches += [EpisodeBatch(f"adaptive gain={g:g}", "adaptive", (("gain_deg_per_m_s", g),), "tuning",
                             TUNING_BENCHES) for g in ADAPTIVE_GRID]
    results = run_tasks(run_batch, batches, executor=executor, progress=True, desc="tuning",
                        checkpoint=TaskCheckpoint(out_dir / "tasks"))
    rows = [[b.label, *[summarise(r)[k] for k in ("n_episodes", "success_rate", "mimicry_error_mm", "score")]]
            for b, r in zip(batches, results)]
    scores = [summarise(r)["score"] for r in results]
    best_pi = int(np.argmin(scores[:len(PI_GRID)]))
    best_ad = int(np.argmin(scores[len(PI_GRID):]))
    return dict(batches[best_pi].params), dict(batches[len(PI_GRID) + best_ad].params), rows


def scripted_batches(pi: dict[str, float], adaptive: dict[str, float], bench_set: str, env_kwargs: tuple,
                     tip: float | None, assumed_tip_deg: float) -> list[EpisodeBatch]:
    n = N_HELDOUT
    mm = (("tip_friction_deg", assumed_tip_deg),)
    return [EpisodeBatch("fixed_tip", "fixed_tip", (), bench_set, n, tip, env_kwargs),
            EpisodeBatch("moment_matching", "moment_matching", mm, bench_set, n, tip, env_kwargs),
            EpisodeBatch("pi_feedback", "pi_feedback", tuple(pi.items()) + mm, bench_set, n, tip, env_kwargs),
            EpisodeBatch("adaptive", "adaptive", tuple(adaptive.items()), bench_set, n, tip, env_kwargs)]


def run_bench_study(out_dir: str | Path, *, seeds: Sequence[int] = (0, 1, 2), ppo_timesteps: int = 300_000,
                    recurrent_timesteps: int | None = 150_000, design_ppo_timesteps: int = 40_000,
                    in_sample_run: str | Path | None = None, designs: Sequence[Design] = DESIGNS,
                    executor: ExecutorLike = None, log=print) -> dict[str, Any]:
    """The whole study (resumable in ``out_dir``); ``recurrent_timesteps=None`` leaves the recurrent PPO out."""
    from agents.train_robust import seed_tasks, train_robust

    from . import bench_plots
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    timings: dict[str, float] = {}
    started = time.perf_counter()
    pi, adaptive, tuning_rows = tune(out_dir, executor)
    _csv(out_dir / "tuning.csv", ["candidate", "n_episodes", "success_rate", "mimicry_error_mm", "score"], tuning_rows)
    log(f"tuned: PI {pi}, adaptive {adaptive}")
    timings["tuning_s"] = time.perf_counter() - started

    started = time.perf_counter()
    tasks = seed_tasks(out_dir / "ppo_robust", seeds, ppo_timesteps)
    if recurrent_timesteps is not None:
        tasks += seed_tasks(out_dir / "ppo_recurrent", seeds, recurrent_timesteps, algo="recurrent")
    trained = run_tasks(train_robust, tasks, executor=executor, progress=True, desc="robust PPO seeds",
                        checkpoint=TaskCheckpoint(out_dir / "tasks"))
    runs = [r for t, r in zip(tasks, trained) if t.algo == "ppo"]
    recurrent_runs = [r for t, r in zip(tasks, trained) if t.algo == "recurrent"]
    timings["ppo_robust_s"] = time.perf_counter() - started  # (both kinds: they share the executor's workers)
    timings["ppo_training_wall_s_per_seed"] = {f"{r['algo']}_seed_{r['seed']}": r["wall_s"] for r in trained}

    # held-out and nominal evaluation on the default bench
    started = time.perf_counter()
    batches: list[EpisodeBatch] = []
    for bench_set in ("nominal", "heldout"):
        batches += [EpisodeBatch("steel_tip", "fixed_tip", (), bench_set),
                    EpisodeBatch("teflon_tip", "fixed_tip", (), bench_set, N_HELDOUT, 3.0),
                    EpisodeBatch("frictionless_tip", "fixed_tip", (), bench_set, N_HELDOUT, 0.0),
                    EpisodeBatch("tracking_tip", "tracking_tip", (), bench_set)]
        batches += scripted_batches(pi, adaptive, bench_set, (), None, 8.0)[1:]
        batches += [EpisodeBatch("ppo_robust", f"ppo:{r['run_dir']}", (), bench_set) for r in runs]
        batches += [EpisodeBatch("ppo_recurrent", f"ppo_recurrent:{r['run_dir']}", (), bench_set)
                    for r in recurrent_runs]
        if in_sample_run is not None:
            batches.append(EpisodeBatch("ppo_in_sample", f"ppo_state:{in_sample_run}", (), bench_set))
    results = run_tasks(run_batch, batches, executor=executor, progress=True, desc="held-out evaluation",
                        checkpoint=TaskCheckpoint(out_dir / "tasks"))
    pooled: dict[tuple[str, str], list[Outcome]] = {}
    for batch, outcomes in zip(batches, results):
        pooled.setdefault((batch.label, batch.bench_set), []).extend(outcomes)
    heldout_rows = [[name, bench_set, *[summarise(o)[k] for k in ("n_episodes", "success_rate", "mimicry_error_mm",
                                                                   "score")]]
                    for (name, bench_set), o in pooled.items()]
    _csv(out_dir / "heldout.csv", ["controller", "bench_set", "n_episodes", "success_rate", "mimicry_error_mm",
                                   "score"], [_fmt(r) for r in heldout_rows])
    _csv(out_dir / "heldout_episodes.csv", ["controller", "bench_set", "index", "load_N", "success", "reason",
                                    "mimicry_error_mm", "travel_m", "return", "steps"],
         [[o.controller, o.bench_set, o.index, f"{o.load_N:.3f}", int(o.success), o.reason,
           f"{o.mimicry_error_mm:.4f}", f"{o.travel_m:.5f}", f"{o.episode_return:.4f}", o.steps]
          for outcomes in results for o in outcomes])
    timings["evaluation_s"] = time.perf_counter() - started

    # the design sweep
    started = time.perf_counter()
    design_runs = run_tasks(_design_ppo, [(str(out_dir / "ppo_designs" / d.name), d, design_ppo_timesteps)
                                          for d in designs],
                            executor=executor, progress=True, desc="design PPO",
                            checkpoint=TaskCheckpoint(out_dir / "tasks"))
    batches = []
    for design, run in zip(designs, design_runs):
        kwargs = tuple(sorted(design.env_kwargs().items()))
        batches += [EpisodeBatch(f"{design.name}|{b.label}", b.controller, b.params, "heldout", N_HELDOUT,
                                 design.tip_friction_deg, kwargs)
                    for b in scripted_batches(pi, adaptive, "heldout", kwargs, design.tip_friction_deg,
                                              design.tip_friction_deg)]
        batches.append(EpisodeBatch(f"{design.name}|ppo_robust", f"ppo:{run['run_dir']}", (), "heldout", N_HELDOUT,
                                    design.tip_friction_deg, kwargs))
    results = run_tasks(run_batch, batches, executor=executor, progress=True, desc="design sweep",
                        checkpoint=TaskCheckpoint(out_dir / "tasks"))
    design_rows = []
    by_name = {d.name: d for d in designs}
    for batch, outcomes in zip(batches, results):
        name, controller = batch.label.split("|")
        d, s = by_name[name], summarise(outcomes)
        design_rows.append([name, d.tip_friction_deg, d.stage_bandwidth_hz, d.latency_s, d.sensor_noise_m,
                            controller, s["success_rate"], s["mimicry_error_mm"], s["score"], d.demand()])
    rows_out = _best_rows(design_rows)
    _csv(out_dir / "designs.csv", ["design", "tip_friction_deg", "stage_bandwidth_hz", "latency_s", "sensor_noise_m",
                                   "controller", "success_rate", "mimicry_error_mm", "score", "demand"],
         [_fmt(r) for r in rows_out])
    timings["design_sweep_s"] = time.perf_counter() - started
    recommendation = recommend(rows_out)
    _write_atomic(out_dir / "recommendation.txt", lambda p: p.write_text(recommendation + "\n"))
    bench_plots.write_all(out_dir, heldout_rows, rows_out, [Path(r["run_dir"]) for r in runs + recurrent_runs])
    summary = {"pi_gains": pi, "adaptive_gain": adaptive, "timings_s": timings, "seeds": list(seeds),
               "ppo_timesteps": ppo_timesteps, "recurrent_timesteps": recurrent_timesteps,
               "trained_timesteps": {f"{r['algo']}_seed_{r['seed']}": r["timesteps"] for r in trained},
               "design_ppo_timesteps": design_ppo_timesteps,
               "n_heldout": N_HELDOUT, "recommendation": recommendation}
    _write_atomic(out_dir / "bench_summary.json", lambda p: p.write_text(json.dumps(summary, indent=2)))
    log(recommendation)
    return summary


def _design_ppo(task: tuple[str, Design, int]) -> dict[str, Any]:
    from agents.train_robust import RobustTask, train_robust
    out, design, timesteps = task
    kwargs = {**design.env_kwargs(), "tip_friction_deg": design.tip_friction_deg}
    return train_robust(RobustTask(out, 0, timesteps, tuple(sorted(kwargs.items())), max(timesteps // 2, 1)))


def _best_rows(rows: list[list[Any]]) -> list[list[Any]]:
    """Per design: the best scripted controller (lowest score, as ``best_scripted:<name>``) and robust PPO."""
    out = []
    for name in dict.fromkeys(r[0] for r in rows):
        mine = [r for r in rows if r[0] == name]
        scripted = [r for r in mine if not r[5].startswith("ppo")]
        best = min(scripted, key=lambda r: r[8])
        out.append(best[:5] + [f"best_scripted:{best[5]}"] + best[6:])
        out += [r for r in mine if r[5].startswith("ppo")]
    return out


def recommend(rows: list[list[Any]]) -> str:
    ok = [r for r in rows if r[6] >= TARGET_SUCCESS and not math.isnan(r[7]) and r[7] < TARGET_ERROR_MM]
    if not ok:
        best = min(rows, key=lambda r: r[8])
        return (f"No design keeps the held-out mimicry error under {TARGET_ERROR_MM:g} mm with at least "
                f"{100 * TARGET_SUCCESS:g} % success. The best score is {best[8]:.2f} mm ({best[0]}, {best[5]}: "
                f"success {100 * best[6]:.0f} %, error over successes {best[7]:.2f} mm).")
    r = min(ok, key=lambda r: (r[9], r[8]))
    return (f"Least demanding design meeting the target: {r[0]} (tip {r[1]:g} deg, stage {r[2]:g} Hz, latency "
            f"{1e3 * r[3]:g} ms, noise {1e3 * r[4]:g} mm) with {r[5]}: success {100 * r[6]:.0f} %, "
            f"mimicry error {r[7]:.2f} mm.")


def _fmt(row: Sequence[Any]) -> list[Any]:
    return [f"{v:.4g}" if isinstance(v, float) else v for v in row]


def main(argv: Iterable[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.bench_study", description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="output directory (resumes what is there)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--ppo-timesteps", type=int, default=300_000, help="frame-stacked robust PPO, per seed")
    parser.add_argument("--recurrent-timesteps", type=int, default=150_000,
                        help="recurrent PPO (RecurrentPPO, LSTM), per seed; 0 leaves it out")
    parser.add_argument("--design-ppo-timesteps", type=int, default=40_000)
    parser.add_argument("--in-sample-run", help="a finished v0 PPO run directory (agents.train_ppo) to evaluate")
    args = parser.parse_args(None if argv is None else list(argv))
    if args.recurrent_timesteps < 0:
        parser.error("--recurrent-timesteps must be >= 0")
    for name in ("ppo_timesteps", "design_ppo_timesteps"):
        if getattr(args, name) <= 0:
            parser.error(f"--{name.replace('_', '-')} must be positive")
    if args.in_sample_run and not (Path(args.in_sample_run) / "final_model.zip").exists():
        parser.error(f"--in-sample-run {args.in_sample_run}: no final_model.zip there")
    run_bench_study(args.out, seeds=args.seeds, ppo_timesteps=args.ppo_timesteps,
                    recurrent_timesteps=args.recurrent_timesteps or None,
                    design_ppo_timesteps=args.design_ppo_timesteps, in_sample_run=args.in_sample_run)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
