"""Plots of the bench study (:mod:`experiments.bench_study`) and of ``triplanar evaluate``, written next to their
tables: distributions and intervals, never bars that hide them. Every row is one controller on one bench set:
its successful episodes' errors as points (one per episode and seed), the mean error with its 95 % interval
(hierarchical bootstrap), the worst decile's mean (CVaR 10 %), and the success rate with its interval
(:func:`experiments.stats.success_ci`)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from triplanar.plotting import plt, save_figure

TARGET_MM = 1.0
COLOURS = {"nominal": "tab:grey", "heldout": "tab:blue", "stress": "tab:red"}

Row = tuple[str, str, dict[str, Any], Sequence[Sequence[Any]]]   # (label, bench set, stats, outcomes per seed)


def _errors(outcomes: Sequence[Sequence[Any]]) -> np.ndarray:
    values = np.array([o.mimicry_error_mm for seed in outcomes for o in seed], dtype=float)
    return values[np.isfinite(values)]


def _failures(outcomes: Sequence[Sequence[Any]]) -> int:
    return sum(not o.success for seed in outcomes for o in seed)


def _error_axis(ax: Any, rows: Sequence[Row]) -> float:
    """A log axis of mm that reads at every scale (ticks at 1, 2 and 5 of each decade, each labelled as a plain
    number: 0.05, 0.1, 0.2, ...), spanning the episodes' errors and the 1 mm target, with a column at the right for
    the failed episodes; returns that column's position."""
    errors = np.concatenate([_errors(r[3]) for r in rows] + [np.array([TARGET_MM])])
    errors = errors[errors > 0]
    low, high = float(errors.min()) / 1.6, float(errors.max()) * 1.6
    failed_at = high * 1.8
    ax.set_xscale("log")
    ax.set_xlim(low, failed_at * 1.8)
    ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}" if v < high * 1.1 else ""))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.axvline(high * 1.3, color="0.7", lw=0.6)
    ax.text(failed_at, 1.0, "failed", transform=ax.get_xaxis_transform(), ha="center", va="bottom", fontsize=7,
            color="tab:red")
    return failed_at


def _xerr(value: float, low: float, high: float) -> list[list[float]]:
    """Error-bar lengths; a percentile interval need not contain the point estimate (small, skewed samples), so
    a side that would be negative is drawn as zero."""
    return [[max(0.0, value - low)], [max(0.0, high - value)]]


def rows_plot(path: Path, rows: Sequence[Row], title: str) -> None:
    """One line per row (controller and bench set), labels on the left: error distribution with the mean's
    interval (left panel, log scale: the errors span 0.1-20 mm) and success rate with its interval (right)."""
    n = len(rows)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 1.2 + 0.32 * n), sharey=True,
                                 gridspec_kw={"width_ratios": [3, 1]}, layout="constrained")
    rng = np.random.default_rng(0)  # jitter only
    y = np.arange(n)[::-1]
    seen: set[str] = set()
    failed_at = _error_axis(a1, rows)
    for yi, (label, bench_set, s, outcomes) in zip(y, rows):
        colour = COLOURS.get(bench_set, "tab:purple")
        errors = _errors(outcomes)
        a1.scatter(errors, yi + rng.uniform(-0.25, 0.25, errors.size), s=4, alpha=0.35, color=colour, lw=0,
                   label=None if bench_set in seen else bench_set)
        seen.add(bench_set)
        failed = _failures(outcomes)
        if failed:   # an episode without an error still counts: drawn in the failed column, with their number
            a1.scatter(np.full(failed, failed_at), yi + rng.uniform(-0.25, 0.25, failed), s=14, marker="x",
                       color="tab:red", lw=0.8, label=None if "failed" in seen else "failed episode")
            a1.annotate(str(failed), (failed_at, yi), xytext=(8, 0), textcoords="offset points", va="center",
                        fontsize=7, color="tab:red")
            seen.add("failed")
        if np.isfinite(s["mimicry_error_mm"]):
            a1.errorbar(s["mimicry_error_mm"], yi, xerr=_xerr(s["mimicry_error_mm"], s["error_low_mm"],
                                                              s["error_high_mm"]),
                        fmt="D", color="k", ms=4, capsize=3, lw=1.2)
            a1.plot(s["cvar10_mm"], yi, marker="|", color="k", ms=9)
        rate = 100 * s["success_rate"]
        a2.errorbar(rate, yi, xerr=_xerr(rate, 100 * s["success_low"], 100 * s["success_high"]), fmt="o",
                    color=colour, capsize=3)
    a1.axvline(TARGET_MM, color="k", lw=0.8, ls="--")
    a1.set_yticks(y, [f"{r[0]} ({r[1]})" for r in rows], fontsize=8)
    a1.set_xlabel("mimicry error of successful episodes, mm (points: episodes; diamond: mean with 95 % CI; "
                  "bar: worst-decile mean;\ndashed: the 1 mm target; x: failed episodes, with their number)", fontsize=8)
    a1.legend(fontsize=7, loc="best", markerscale=1.5)
    a2.set_xlabel("success rate, % (95 % CI)", fontsize=8)
    a2.set_xlim(min(50.0, min(100 * r[2]["success_low"] for r in rows) - 5), 101)
    fig.suptitle(title, fontsize=10)
    save_figure(fig, path, dpi=110)


def designs_plot(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """The design sweep: one line per design and controller, sorted by hardware demand, labels on the left; mean
    error with its 95 % interval and the success rate with its interval."""
    n = len(rows)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 1.2 + 0.3 * n), sharey=True, gridspec_kw={"width_ratios": [3, 1]},
                                 layout="constrained")
    y = np.arange(n)[::-1]
    for yi, r in zip(y, rows):
        colour = "tab:orange" if r["controller"].startswith("ppo") else "tab:blue"
        if np.isfinite(r["mimicry_error_mm"]):
            a1.errorbar(r["mimicry_error_mm"], yi, xerr=_xerr(r["mimicry_error_mm"], r["error_low_mm"],
                                                              r["error_high_mm"]),
                        fmt="D", color=colour, ms=4, capsize=3)
        rate = 100 * r["success_rate"]
        a2.errorbar(rate, yi, xerr=_xerr(rate, 100 * r["success_low"], 100 * r["success_high"]), fmt="o",
                    color=colour, capsize=3)
    a1.axvline(TARGET_MM, color="k", lw=0.8, ls="--")
    a1.set_yticks(y, [f"{r['design']} (demand {r['demand']}): {r['controller']}" for r in rows], fontsize=7)
    a1.set_xlabel("held-out mimicry error over successes, mm (mean, 95 % CI); blue: best scripted, orange: robust "
                  "PPO; dashed: the 1 mm target", fontsize=8)
    a2.set_xlabel("success rate, % (95 % CI)", fontsize=8)
    fig.suptitle("Design sweep (TriPlanarShear-v1, held-out benches with each design's tip)", fontsize=10)
    save_figure(fig, path, dpi=110)


def curves_plot(path: Path, run_dirs: Sequence[Path]) -> None:
    """Robust PPO's learning curves on the tuning benches: success rate, error over successes, score (one line per
    run, named ``kind/seed_S``: ``ppo_robust`` frame stack, ``ppo_recurrent`` LSTM)."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for run in run_dirs:
        with open(run / "learning_curve.csv") as f:
            rows = list(csv.DictReader(f))
        t = [float(r["timesteps"]) for r in rows]
        for ax, key in zip(axes, ("success_rate", "mimicry_error_mm", "score")):
            ax.plot(t, [float(r[key]) for r in rows], marker=".", label=f"{run.parent.name}/{run.name}",
                    ls="--" if "recurrent" in run.parent.name else "-")
    for ax, label in zip(axes, ("success rate", "mimicry error over successes, mm", "score (failure = 10 mm), mm")):
        ax.set_xlabel("timesteps")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    save_figure(fig, path, dpi=110)
