"""The study's numbers (``summary``) and its report (``write_markdown``, written with ``study --doc``)."""

from __future__ import annotations

import os
from datetime import date
from pathlib import Path
from typing import Any

import numpy as np

from triplanar.atomic import write_atomic
from triplanar.outcome import Outcome

from .plots import slug
from .study_result import StudyResult


PPO = "PPO"
TARGET_CONTROLLER = "tracking tip"
REFERENCE_ONLY = ("frictionless tip",)  # hypothetical hardware, shown for scale, not ranked


def _ranges(loads: list[float], flags: list[bool]) -> str:
    """'27.8-37.5, 45 N' style list of the loads where ``flags`` holds."""
    runs, current = [], []
    for load, flag in zip(loads, flags):
        if flag:
            current.append(load)
        elif current:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    return ", ".join(f"{r[0]:g}" if len(r) == 1 else f"{r[0]:g}-{r[-1]:g}" for r in runs) + " N" if runs else "none"


def summary(result: StudyResult) -> dict[str, Any]:
    loads = list(result.loads)
    scripted = [c for c in result.controllers if c != PPO and c not in REFERENCE_ONLY]
    out: dict[str, Any] = {"loads_N": loads, "controllers": {}, "scripted": scripted}
    for c in result.controllers:
        table = result.errors(c)
        failures = [(r.load_N, r.seed, r.reason) for r in result.episodes if r.controller == c and not r.success]
        out["controllers"][c] = {"mean_by_load_mm": table.mean(axis=0).round(4).tolist(),
                                 "std_by_load_mm": table.std(axis=0).round(4).tolist(),
                                 "mean_over_loads_mm": round(float(table.mean()), 4),
                                 "seeds": table.shape[0], "failures": failures}
    best = [min(scripted, key=lambda c: result.errors(c)[0, j]) for j in range(len(loads))]
    out["best_scripted_by_load"] = best
    out["stage_limit_loads"] = {c: [r.load_N for r in result.episodes if r.controller == c
                                    and np.abs(r.actions[:, 1]).max() >= 0.999] for c in result.controllers}
    if PPO in result.controllers:
        ppo = result.errors(PPO)
        best_err = np.array([result.errors(best[j])[0, j] for j in range(len(loads))])
        out["ppo_beats_best_scripted_at"] = [f for j, f in enumerate(loads) if ppo[:, j].mean() < best_err[j]]
        out["ppo_worst_seed_beats_best_scripted_at"] = [f for j, f in enumerate(loads) if ppo[:, j].max() < best_err[j]]
        out["ppo_loses_to_best_scripted_at"] = [f for j, f in enumerate(loads) if ppo[:, j].mean() >= best_err[j]]
        out["ppo_vs"] = {c: int(np.sum(ppo.mean(axis=0) < result.errors(c)[0])) for c in scripted}
    if TARGET_CONTROLLER in result.controllers and result.curves:
        target = float(result.errors(TARGET_CONTROLLER)[0, 0])
        column, reason = f"error_mm_{loads[0]:g}N", f"reason_{loads[0]:g}N"
        reached = {}
        for seed, curve in result.curves.items():
            hits = np.flatnonzero((curve[column] <= target) & (curve[reason] == Outcome.TRAVEL.label))
            reached[seed] = None if not len(hits) else {"timesteps": int(curve["timesteps"][hits[0]]),
                                                         "wall_s": float(curve["wall_s"][hits[0]])}
        out["time_to_target"] = {"target_mm": target, "load_N": loads[0], "controller": TARGET_CONTROLLER,
                                 "by_seed": reached}
    if PPO in result.controllers:
        from triplanar import paper_model, simulate
        ppo_runs = [r for r in result.episodes if r.controller == PPO]
        out["ppo_strategy"] = {f"{f:g}": {
            "thrust_min_N": round(min(float(r.thrust_N.min()) for r in runs), 2),
            "thrust_max_N": round(max(float(r.thrust_N.max()) for r in runs), 2),
            "offset_max_abs_mm": round(max(float(np.abs(r.offset_m).max()) for r in runs) * 1e3, 2),
            "duration_s": [round(r.duration_s, 4) for r in runs],
            "hydrostatic_duration_s": round(float(simulate(paper_model("C", f)).t[-1]), 4)}
            for f in loads for runs in [[r for r in ppo_runs if r.load_N == f]]}
    out["training"] = {run.run_dir.name: {"timesteps": run.timesteps, "wall_s": round(run.wall_s, 1)}
                       for run in result.ppo_runs}
    out["timings_s"] = {k: round(v, 1) for k, v in result.timings.items()}
    return out


def _table(result: StudyResult, summary_: dict[str, Any]) -> str:
    names = result.controllers
    head = "| load (N) | " + " | ".join(names) + " |\n|---|" + "---|" * len(names) + "\n"
    rows = []
    for j, load in enumerate(result.loads):
        cells = []
        for c in names:
            table = result.errors(c)
            runs = [r for r in result.episodes if r.controller == c and r.load_N == load]
            mark = "" if all(r.success for r in runs) else " (" + ", ".join(sorted({r.reason for r in runs
                                                                                    if not r.success})) + ")"
            cell = f"{table[0, j]:.2f}" if table.shape[0] == 1 else f"{table[:, j].mean():.2f} +- {table[:, j].std():.2f}"
            if c == summary_["best_scripted_by_load"][j]:
                cell = f"**{cell}**"
            cells.append(cell + mark)
        rows.append(f"| {load:g} | " + " | ".join(cells) + " |")
    means = [f"{summary_['controllers'][c]['mean_over_loads_mm']:.2f}" for c in names]
    rows.append("| mean | " + " | ".join(means) + " |")
    return head + "\n".join(rows) + "\n"


def _answer(c: dict[str, Any], best_overall: str) -> str:
    """The study's answer in one sentence: can the actuator reproduce case C (within this model)?"""
    ppo = c.get(PPO)
    best_scripted_mean = c[best_overall]["mean_over_loads_mm"]
    if not ppo:
        return f"Among the scripted laws, {best_overall} comes closest ({best_scripted_mean:.2f} mm on average)."
    ppo_mean, ppo_max = ppo["mean_over_loads_mm"], max(ppo["mean_by_load_mm"])
    if not ppo["failures"] and ppo_max < 1.0:
        return (f"Within this model, yes: the learned policy follows the hydrostatic path to {ppo_mean:.2f} mm on "
                f"average (at most {ppo_max:.2f} mm at any load, every seed reaching 8 cm), "
                f"{best_scripted_mean / ppo_mean:.0f} times closer than the best scripted law ({best_overall}, "
                f"{best_scripted_mean:.2f} mm). The scripted laws show why it is hard: each removes one cause of "
                "the difference (friction, load-point drift, moment) but not all of them at once.")
    return (f"Partly: PPO reaches {ppo_mean:.2f} mm on average (worst load {ppo_max:.2f} mm) against "
            f"{best_scripted_mean:.2f} mm for the best scripted law ({best_overall}).")


def _strategy(s: dict[str, Any], loads: list[float]) -> str:
    """How PPO's policies use the actuator, at the lowest and highest load."""
    if "ppo_strategy" not in s:
        return "No PPO runs."
    lo, hi = s["ppo_strategy"][f"{loads[0]:g}"], s["ppo_strategy"][f"{loads[-1]:g}"]
    return (f"PPO's policies use the actuator in a way no scripted law does: at {loads[0]:g} N the thrust "
            f"ranges over {lo['thrust_min_N']:.0f}-{lo['thrust_max_N']:.0f} N (the hydrostatic load is a "
            f"constant {loads[0]:g} N) and the tip moves up to {lo['offset_max_abs_mm']:.0f} mm off the "
            f"centreline (at {loads[-1]:g} N: {hi['thrust_min_N']:.0f}-{hi['thrust_max_N']:.0f} N, "
            f"{hi['offset_max_abs_mm']:.0f} mm). They reproduce the path by travel, not the hydrostatic test's "
            f"time history: at {loads[0]:g} N their tests last "
            f"{', '.join(f'{d:.2f}' for d in lo['duration_s'])} s against {lo['hydrostatic_duration_s']:.2f} s "
            f"under hydrostatic load ({loads[-1]:g} N: {', '.join(f'{d:.2f}' for d in hi['duration_s'])} s "
            f"against {hi['hydrostatic_duration_s']:.2f} s). The reward asks for the path only.")


def _seeds(s: dict[str, Any]) -> int:
    ppo = s["controllers"].get(PPO)
    return ppo["seeds"] if ppo else 0


def _head(result: StudyResult, rel: Path) -> str:
    return f"""# Actuator design study: can a servo actuator make the block slide as under hydrostatic load?

Generated by `triplanar study --out {result.out_dir}` on {date.today().isoformat()}: every number below is from
that run (PPO runs in `{result.ppo_runs[0].run_dir.parent if result.ppo_runs else '-'}`, trained by the command or
reused when finished); tables and figures in [`{rel}`]({rel}). Environment: `TriPlanarShear-v0` (`envs/`,
documented in its docstring and `docs/environment.md`), controllers in `agents/`.

"""


def _question_and_controllers(seeds: int) -> str:
    return f"""## Question

The laboratory pushes the block with a steel tip that rubs on the aft face (end friction, 8 degrees). Galic,
Glaser & Goodman (2008) show that this changes the sliding path, and that the bench is far from the hydrostatic
(water-pressure) loading it is meant to represent: their case C, a frictionless force normal to the aft face at the
body-fixed centreline point `P_CL`. Can an actuator that sets its thrust and moves its tip sideways on a
rate-limited stage (0.5 m/s, +-20 mm) cancel the end friction and reproduce case C?

**Metric.** The mimicry error is the horizontal distance between the block's contact points and the case-C
reference path of the same model, specimen and load level *at the same travel* (CP1's displacement along e1, the
paper's parametrisation), averaged over the three contact points and over the travel (0 to 8 cm). It is what the
reward accumulates (`r_distance`); a controller that does not reach 8 cm is marked by its outcome.

## Controllers

1. **steel tip** (the laboratory today, case A): constant thrust at the load level, tip fixed on the centreline.
2. **teflon tip**: the same with a 3-degree tip (`tip_friction_deg=3`).
3. **tracking tip**: steel tip, constant thrust; the stage follows the aft-face centreline (commanded to the
   observed centreline position plus one period of the face's lateral motion), so the tip does not slip sideways.
4. **moment matching** (model-based). The hydrostatic load `F g1` at `P_CL` has the yaw moment (about the
   vertical through the mass centre C) `M_C = F (r_3 g1_1 - r_1 g1_3)`, `r = P_CL - C`. The actuator pushes
   `T e1` on the tip line `x3 = P0_CL,3 + u` and its lateral end friction `f3` acts at lever `l = C_1 - x1_L`:
   yaw moment `T (x3_L - C_3) + l f3`. Choosing `T = F g1_1` (the same e1 component) and equal moments gives
   `u = u* - l f3 / T` with the frictionless solution `u* = P_CL,3 - P0_CL,3 + l g1_3 / g1_1`. The end friction is
   Coulomb's, `f3 = -T g1_1 tan(phi_EF) sign(s)`, with the lateral slip `s = v_face - du/dt` that the command itself
   implies; `u` is found by two fixed-point passes from `u*`. The pose (g1, C, `P_CL`) is computed from the observed
   contact points and the specimen's geometry. Without the friction term (`u*` alone) the error at 27.8 N is
   ~16 mm: the tip then slides on the face and the end friction's moment is as large as the one being matched.
   With it, the fixed point has no solution while the tip is nearly stuck, and the passes alternate: the stage
   dithers by about +-2.5 mm every period, which averages the lateral end friction out. That is a real effect
   (a dithered tip), but it is a demanding use of the stage (its action-rate penalty is high).
5. **PPO** (stable-baselines3, `agents/ppo.yaml`): one policy for all 12 loads, {seeds} seeds, VecNormalize,
   deterministic evaluation. It observes the reference path at the current travel (as every controller may), and
   is the only controller that uses it.

For scale, **frictionless tip** is a fixed tip with no end friction at all (the paper's case B): hypothetical
hardware, not ranked among the scripted controllers.

"""


def _results(result: StudyResult, s: dict[str, Any], rel: Path, seeds: int) -> str:
    figures = "\n".join(f"* {n}: [traces_{slug(n)}.png]({rel / f'traces_{slug(n)}.png'})" for n in result.controllers)
    return f"""## Results

Mimicry error (mm), one deterministic episode per load (the environment is deterministic; PPO: mean +- std over
{seeds} seeds); **bold**: best scripted controller at that load; an outcome in brackets means the episode did not
reach 8 cm. CSV: [`mimicry_table.csv`]({rel / 'mimicry_table.csv'}), per episode
[`episodes.csv`]({rel / 'episodes.csv'}).

{_table(result, s)}
![errors by load]({rel / 'errors_by_load.png'})

Traces against the hydrostatic reference, every load level:

{figures}

Commands at {result.loads[0]:g} N: [actions_{result.loads[0]:g}N.png]({rel / f'actions_{result.loads[0]:g}N.png'}).
Learning curves: [learning_curves.png]({rel / 'learning_curves.png'}).

"""


def _ppo_baseline(result: StudyResult, s: dict[str, Any]) -> str:
    ttt = s.get("time_to_target", {})
    ttt_lines = "\n".join(
        f"* seed {seed}: " + (f"{v['timesteps']:,} steps, {v['wall_s']:.0f} s" if v else "not reached")
        for seed, v in ttt.get("by_seed", {}).items())
    training = "\n".join(f"* {name}: {v['timesteps']:,} steps in {v['wall_s'] / 60:.1f} min"
                         for name, v in s["training"].items())
    beats = s.get("ppo_beats_best_scripted_at", [])
    loses = s.get("ppo_loses_to_best_scripted_at", [])
    worst_beats = s.get("ppo_worst_seed_beats_best_scripted_at", [])
    return f"""### PPO as a baseline

Training (one core, `torch.set_num_threads(1)`, batched env `agents.sb3_vec_env.ShearSB3VecEnv`):

{training}

Wall-clock until the deterministic policy first beat the tracking tip's error at {ttt.get('load_N', 0):g} N
({ttt.get('target_mm', float('nan')):.2f} mm) and reached 8 cm, evaluated every 25,000 steps:

{ttt_lines}

PPO's mean beats the best scripted controller at {len(beats)} of {len(result.loads)} loads
({', '.join(f'{f:g}' for f in beats) or 'none'}); its worst seed does at {len(worst_beats)}
({', '.join(f'{f:g}' for f in worst_beats) or 'none'}); it loses at {', '.join(f'{f:g}' for f in loses) or 'none'}.
Loads at which PPO's mean beats each scripted controller: {', '.join(f'{k} {v}/12' for k, v in s.get('ppo_vs', {}).items())}.

"""


def _conclusions(result: StudyResult, s: dict[str, Any]) -> str:
    c = s["controllers"]
    loads = list(result.loads)
    best_overall = min(s["scripted"], key=lambda n: c[n]["mean_over_loads_mm"])
    best_by_load = s["best_scripted_by_load"]
    best_lines = "; ".join(f"{n} at {_ranges(loads, [b == n for b in best_by_load])}"
                           for n in dict.fromkeys(best_by_load))
    failures = {n: v["failures"] for n, v in c.items() if v["failures"]}
    limits = {n: v for n, v in s["stage_limit_loads"].items() if v}
    answer, strategy = _answer(c, best_overall), _strategy(s, loads)
    return f"""## Conclusions

* {answer}
* The steel tip is far from hydrostatic loading: {c['steel tip']['mean_by_load_mm'][0]:.1f} mm at
  {loads[0]:g} N, {c['steel tip']['mean_by_load_mm'][-1]:.1f} mm at {loads[-1]:g} N (the end effect shrinks as
  the load grows, the paper's "velocity shielding").
* A teflon tip (3 degrees) roughly halves the steel tip's error ({c['teflon tip']['mean_over_loads_mm']:.2f} mm on
  average against {c['steel tip']['mean_over_loads_mm']:.2f}); even 3 degrees of end friction matters, since a tip
  with none at all (the paper's case B, shown for scale as "frictionless tip") gets
  {c['frictionless tip']['mean_over_loads_mm'] if 'frictionless tip' in c else float('nan'):.2f} mm. A fixed tip
  line cannot follow the block's lateral drift either way.
* The tracking tip ({c['tracking tip']['mean_over_loads_mm']:.2f} mm on average) keeps the load point on the
  centreline and the tip stuck to the face, which is close to the body-fixed hydrostatic load point; it is poor at
  low loads, where the block turns and drifts most. Its stage command reaches the +-20 mm limit at
  {_ranges(loads, [f in limits.get('tracking tip', []) for f in loads])}.
* Moment matching ({c['moment matching']['mean_over_loads_mm']:.2f} mm on average) is the most even scripted law;
  it works through the dither its friction compensation produces.
* {strategy}
* Best scripted law by load: {best_lines}. Best on average: {best_overall}.
* Episodes that did not reach 8 cm: {failures if failures else 'none'}.

"""


def _caveats_and_reproduce(result: StudyResult, path: Path, seeds: int) -> str:
    return f"""## Caveats

* Everything is the model's: the reference specimen's undocumented values (`docs/specimen-format.md`)
  and Coulomb friction with a velocity-controlled, infinitely stiff stage. A real stage has finite bandwidth; the
  dithering moment-matching controller and any policy with fast stage reversals would need checking on hardware.
* Fixed 5 ms RK4 steps step to each predicted stop of a slip, but cannot follow a slip that stays slow while it
  turns (its direction relaxes too fast for the step), which is what the tracking tip does at the tip. The
  environment checks the energy balance of every period and redoes the period with the kernel's adaptive DOPRI5
  when it is violated by more than 1e-8 J (see `docs/environment.md`); without that check the tracking tip
  scores 2.2 mm instead of 7.7 mm at 27.8 N, on energy the integrator made up.
* PPO's numbers are for {seeds} seeds and one hyperparameter set tuned for speed, not exhaustively.

## Reproduce

```
triplanar study --out {result.out_dir} --ppo-dir runs/ppo --seeds {' '.join(str(k) for k in sorted(result.curves))} --doc {path.name}
```
(trains or resumes PPO, then evaluates; `--skip-train` re-evaluates finished runs; `triplanar train`
trains one run). The files in `--ppo-dir` (`vecnormalize.pkl`, the SB3 zips) are loaded with pickle and
cloudpickle, which run code: use only runs you trained or that come from a trusted source.
"""


def write_markdown(result: StudyResult, s: dict[str, Any], path: Path) -> None:
    """The study's report (Markdown), its numbers from ``s`` (:func:`summary`) and its links relative to ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rel = Path(os.path.relpath(result.out_dir, path.parent))
    seeds = _seeds(s)
    text = (_head(result, rel) + _question_and_controllers(seeds) + _results(result, s, rel, seeds)
            + _ppo_baseline(result, s) + _conclusions(result, s) + _caveats_and_reproduce(result, path, seeds))
    write_atomic(path, lambda tmp: tmp.write_text(text))

