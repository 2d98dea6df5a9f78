"""The bench study's report (``bench_report.md`` next to its tables; ``--doc`` copies it): budgets, wall times,
and every row with its intervals, from what :func:`experiments.bench_study.run_bench_study` computed."""

from __future__ import annotations

import os
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Sequence

from . import tables

HEADER = ("| success, % (95 % CI) | error over successes, mm (95 % CI) | CVaR 10 %, mm | score, mm (95 % CI) "
          "| per seed: error, mm |")


def _pct(r: dict[str, Any]) -> str:
    return f"{100 * r['success_rate']:.1f} ({100 * r['success_low']:.1f}-{100 * r['success_high']:.1f})"


def _mm(value: float, low: float, high: float) -> str:
    return "-" if value != value else f"{value:.2f} ({low:.2f}-{high:.2f})"


def stats_cells(r: dict[str, Any]) -> str:
    seeds = ", ".join("-" if v != v else f"{v:.2f}" for v in r["seed_errors_mm"])
    cvar = "-" if r["cvar10_mm"] != r["cvar10_mm"] else f"{r['cvar10_mm']:.2f}"
    return (f"{_pct(r)} | {_mm(r['mimicry_error_mm'], r['error_low_mm'], r['error_high_mm'])} | {cvar} | "
            f"{_mm(r['score'], r['score_low'], r['score_high'])} | {seeds} |")


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def budgets(summary: dict[str, Any]) -> list[str]:
    t = summary["timings_s"]
    per_seed = ", ".join(f"{k} {_minutes(v)}" for k, v in t.get("ppo_training_wall_s_per_seed", {}).items())
    recurrent = summary["recurrent_timesteps"]
    n_seeds = len(summary["seeds"])
    recurrent_text = "none" if recurrent is None else f"{n_seeds} seeds x {recurrent:,} steps"
    return [
        f"* robust PPO (frame stack): {len(summary['seeds'])} seeds x {summary['ppo_timesteps']:,} steps; recurrent "
        f"PPO: {recurrent_text}; trained "
        f"steps per run: {summary['trained_timesteps']}",
        f"* design sweep: {len(summary['designs'])} designs, robust PPO {len(summary['design_seeds'])} seeds x "
        f"{summary['design_ppo_timesteps']:,} steps per design",
        f"* benches: {summary['n_heldout']} held-out, {summary['n_stress']} stress, the nominal 12 loads; scripted "
        f"controllers: {len(summary['scripted_seeds'])} sensor-noise replicates",
        f"* tuned gains: PI {summary['pi_gains']}, adaptive {summary['adaptive_gain']}",
        "* wall time of the command that wrote this report (a phase resumed from finished tasks reads them back and "
        "takes almost none; each training run's own time is from its run directory): "
        f"tuning {_minutes(t['tuning_s'])}, PPO training {_minutes(t['ppo_training_s'])} (per run: "
        f"{per_seed}), evaluation {_minutes(t['evaluation_s'])}, design sweep {_minutes(t['design_sweep_s'])}",
    ]


def answer(heldout_rows: Sequence[dict[str, Any]], recommendation: str) -> list[str]:
    """The report's first section, what a laboratory reads first: the recommendation, then the default bench's
    controllers by held-out score, those that run in real time first, each beside the information-limited bound
    (what the bench's sensors allow: a bench controller's reference) and with its stress row."""
    from .evaluate import runs_in_real_time
    by = {(r["controller"], r["bench_set"]): r for r in heldout_rows}
    bound = by.get(("information_bound", "heldout"))
    held = sorted((r for r in heldout_rows if r["bench_set"] == "heldout"),
                  key=lambda r: (not runs_in_real_time(r["controller"]), r["score"]))
    lines = ["## The answer", "", recommendation, "",
             "The default bench's controllers on the held-out benches (stress beside), those that run within the "
             "bench's 5 ms period first, by score; the last column is the held-out score over the "
             "information-limited bound's" + ("" if bound else " (no bound row in this run)") + ".", "",
             "| controller | runs in real time | benches x seeds | success, % (95 % CI) | error over successes, mm "
             "(95 % CI) | score, mm (95 % CI) | stress: success, % | stress: score, mm | score / bound's |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in held:
        stress = by.get((r["controller"], "stress"))
        ratio = f"{r['score'] / bound['score']:.2f}" if bound else "-"
        lines.append(f"| `{r['controller']}` | {'yes' if runs_in_real_time(r['controller']) else 'no'} | "
                     f"{r['n_benches']} x {r['n_seeds']} | {_pct(r)} | "
                     f"{_mm(r['mimicry_error_mm'], r['error_low_mm'], r['error_high_mm'])} | "
                     f"{_mm(r['score'], r['score_low'], r['score_high'])} | "
                     f"{_pct(stress) if stress else '-'} | "
                     f"{_mm(stress['score'], stress['score_low'], stress['score_high']) if stress else '-'} | "
                     f"{ratio} |")
    return lines + [""]


def markdown(summary: dict[str, Any], heldout_rows: Sequence[dict[str, Any]],
             design_rows: Sequence[dict[str, Any]], images: str = "") -> str:
    """The report; ``images`` prefixes the PNGs' paths (the study's directory seen from where the report lies)."""
    lines = ["# Bench study report (TriPlanarShear-v1)", "",
             f"Generated {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')} by "
             "`experiments.bench_study` (`triplanar study --bench`). Intervals: 95 %, the error's and score's by "
             "hierarchical bootstrap over seeds and benches, the success rate's as the union of Wilson's score interval "
             "and the hierarchical bootstrap's "
             "(`experiments/stats.py`). Errors are over successful episodes only; the score counts a failure as "
             "10 mm.", "", *answer(heldout_rows, summary["recommendation"]),
             "## Budgets and wall times", "", *budgets(summary), "",
             "## Default bench: nominal, held-out and stress benches", "", f"![held-out]({images}heldout.png)", "",
             "| controller | bench set | benches x seeds " + HEADER, "|---|---|---" + "|---" * 5 + "|"]
    for r in heldout_rows:
        lines.append(f"| `{r['controller']}` | {r['bench_set']} | {r['n_benches']} x {r['n_seeds']} | "
                     + stats_cells(r))
    lines += ["", "## Design sweep (held-out benches, each design's tip)", "", f"![designs]({images}designs.png)", "",
              "| design | demand | controller | benches x seeds " + HEADER, "|---|---|---|---" + "|---" * 5 + "|"]
    for r in design_rows:
        lines.append(f"| {r['design']} | {r['demand']} | `{r['controller']}` | {r['n_benches']} x {r['n_seeds']} | "
                     + stats_cells(r))
    lines += ["", "## Recommendation", "", summary["recommendation"], "",
              f"![learning curves]({images}robust_learning_curves.png)", ""]
    return "\n".join(lines)


def write(out_dir: Path, summary: dict[str, Any], heldout_rows, design_rows, doc: Path | None = None) -> None:
    """``out_dir/bench_report.md``, and the same report at ``doc`` with the images' paths relative to it."""
    text = markdown(summary, heldout_rows, design_rows)
    tables.write_atomic(Path(out_dir) / "bench_report.md", lambda p: p.write_text(text))
    if doc is not None:
        doc = Path(doc)
        doc.parent.mkdir(parents=True, exist_ok=True)
        images = os.path.relpath(Path(out_dir).resolve(), doc.resolve().parent) + "/"
        text = markdown(summary, heldout_rows, design_rows, images)
        tables.write_atomic(doc, lambda p: p.write_text(text))
