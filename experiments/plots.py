"""Figures of the actuator study (overhead views through :mod:`triplanar.plotting`, as every figure of the project)."""

from __future__ import annotations

import re

import numpy as np

from triplanar import plotting
from triplanar.specimen import reference

from .study_result import StudyResult


plt = plotting.plt
COLORS = {"steel tip": "tab:red", "teflon tip": "tab:orange", "tracking tip": "tab:green",
          "moment matching": "tab:purple", "PPO": "tab:blue", "frictionless tip": "0.5"}


def slug(name: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")


def write_all(result: StudyResult) -> None:
    for controller in result.controllers:
        traces(result, controller)
    errors_by_load(result)
    actions(result, load=result.loads[0])
    learning_curves(result)


def traces(result: StudyResult, controller: str) -> None:
    foundation = reference()[1]
    fig, axes = plotting.panel_grid(len(result.loads), size=3.6)
    for ax, load in zip(axes, result.loads):
        runs = [r for r in result.episodes if r.controller == controller and r.load_N == load]
        errors = ", ".join(f"{r.mimicry_error_mm:.2f}" + ("" if r.success else f" ({r.reason})") for r in runs)
        plotting.overhead_axes(ax, foundation, title=f"{load:g} N: {errors} mm")
        ax.set_aspect("equal", adjustable="box")
        plotting.plot_traces(ax, runs[0].reference, color=plotting.MODEL, lw=1.6,
                             label="hydrostatic (case C)")
        for r in runs:
            plotting.plot_traces(ax, r.contact_points, color=plotting.MEASURED, lw=0.8,
                                 label=controller if r is runs[0] else None)
        ax.set_xlim(-0.155, 0.095)
        ax.set_ylim(-0.025, 0.295)
    axes[0].legend(fontsize=7, loc="center left")
    fig.suptitle(f"{controller}: contact-point traces (black) against the hydrostatic reference (grey)")
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    plotting.save_figure(fig, result.out_dir / f"traces_{slug(controller)}.png")


def errors_by_load(result: StudyResult) -> None:
    fig, ax = plt.subplots(figsize=(7, 4.5))
    loads = np.array(result.loads)
    for controller in result.controllers:
        table = result.errors(controller)
        mean = table.mean(axis=0)
        ax.plot(loads, mean, "o-", color=COLORS.get(controller), label=controller, ms=3)
        if table.shape[0] > 1:
            ax.fill_between(loads, table.min(axis=0), table.max(axis=0), color=COLORS.get(controller), alpha=0.2)
    ax.set_yscale("log")
    ax.set_xlabel("load level (N)")
    ax.set_ylabel("mimicry error (mm, travel-averaged)")
    ax.set_title("Distance from the hydrostatic path (PPO: mean, band = min-max over seeds)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    plotting.save_figure(fig, result.out_dir / "errors_by_load.png")


def actions(result: StudyResult, load: float) -> None:
    fig, (ax_t, ax_u) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for controller in result.controllers:
        r = next(e for e in result.episodes if e.controller == controller and e.load_N == load)
        travel = (r.contact_points[1:, 0, 0] - r.contact_points[0, 0, 0]) * 1e3
        ax_t.plot(travel, r.thrust_N, color=COLORS.get(controller), label=controller, lw=1)
        ax_u.plot(travel, r.offset_m * 1e3, color=COLORS.get(controller), lw=1)
    ax_t.set_ylabel("thrust (N)")
    ax_u.set_ylabel("tip offset (mm, rate-limited stage)")
    ax_u.set_xlabel("travel of CP1 (mm)")
    ax_t.legend(fontsize=8)
    ax_t.set_title(f"Commands at {load:g} N (PPO: seed {min(r.seed for r in result.episodes if r.controller == 'PPO')})")
    plotting.save_figure(fig, result.out_dir / f"actions_{load:g}N.png")


def learning_curves(result: StudyResult) -> None:
    if not result.curves:
        return
    fig, (ax_w, ax_m) = plt.subplots(1, 2, figsize=(11, 4))
    first = f"error_mm_{result.loads[0]:g}N"
    for seed, curve in result.curves.items():
        ax_w.plot(curve["wall_s"] / 60.0, curve[first], lw=1, label=f"PPO seed {seed}")
        cols = [k for k in curve if k.startswith("error_mm_")]
        ax_m.plot(curve["timesteps"], np.mean([curve[k] for k in cols], axis=0), lw=1, label=f"PPO seed {seed}")
    for controller in result.controllers:
        if controller == "PPO":
            continue
        errors = result.errors(controller)[0]
        ax_w.axhline(errors[0], color=COLORS.get(controller), ls="--", lw=1, label=controller)
        ax_m.axhline(errors.mean(), color=COLORS.get(controller), ls="--", lw=1, label=controller)
    for ax in (ax_w, ax_m):
        ax.set_yscale("log")
        ax.set_ylabel("mimicry error (mm)")
        ax.grid(alpha=0.3, which="both")
    ax_w.set_xlabel("wall-clock (min, one core)")
    ax_w.set_title(f"At {result.loads[0]:g} N (deterministic policy)")
    ax_m.set_xlabel("environment steps")
    ax_m.set_title("Mean over the 12 load levels")
    ax_m.legend(fontsize=7)
    plotting.save_figure(fig, result.out_dir / "learning_curves.png")
