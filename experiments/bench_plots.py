"""Plots of the bench study (:mod:`experiments.bench_study`), written next to its tables."""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from triplanar.plotting import plt


def _save(fig: Any, path: Path) -> None:
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)


def heldout_plot(out: Path, rows: Sequence[Sequence[Any]]) -> None:
    """Success rate and mimicry error over successful episodes per controller, nominal and held-out."""
    names = list(dict.fromkeys(r[0] for r in rows))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for k, bench_set in enumerate(("nominal", "heldout")):
        got = {r[0]: r for r in rows if r[1] == bench_set}
        x = np.arange(len(names)) + (k - 0.5) * 0.38
        a1.bar(x, [100 * got[n][3] if n in got else 0 for n in names], 0.38, label=bench_set)
        a2.bar(x, [got[n][4] if n in got else math.nan for n in names], 0.38, label=bench_set)
    for ax, label in ((a1, "success rate, %"), (a2, "mimicry error over successes, mm")):
        ax.set_xticks(np.arange(len(names)), names, rotation=35, ha="right")
        ax.set_ylabel(label)
        ax.legend()
    a2.axhline(1.0, color="k", lw=0.8, ls="--")
    fig.suptitle("TriPlanarShear-v1, default bench: nominal specimen (12 loads) and held-out specimens")
    _save(fig, out / "heldout.png")


def designs_plot(out: Path, rows: Sequence[Sequence[Any]]) -> None:
    """Mimicry error (over successes) against hardware demand; marker size shows the success rate."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for kind, marker in (("best_scripted", "o"), ("ppo", "s")):
        mine = [r for r in rows if r[5].startswith(kind)]
        ax.scatter([r[9] for r in mine], [r[7] for r in mine], s=[20 + 80 * r[6] for r in mine], marker=marker,
                   label="best scripted" if kind == "best_scripted" else "robust PPO (short budget)", alpha=0.7)
        for r in mine:
            ax.annotate(r[0], (r[9], r[7]), fontsize=6, xytext=(3, 2), textcoords="offset points")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("hardware demand (ordinal sum: tip, stage bandwidth, latency, sensor noise)")
    ax.set_ylabel("held-out mimicry error over successes, mm")
    ax.legend(fontsize=8)
    _save(fig, out / "designs.png")


def curves_plot(out: Path, run_dirs: Sequence[Path]) -> None:
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
    _save(fig, out / "robust_learning_curves.png")


def write_all(out: Path, heldout_rows, design_rows, run_dirs) -> None:
    heldout_plot(out, heldout_rows)
    designs_plot(out, design_rows)
    curves_plot(out, run_dirs)
