"""Figures of the workbench, in the paper's style (:mod:`triplanar.plotting`: measured black, model grey).

* :func:`plot_overhead`: one overhead panel per load level, every repeat measured (black) and the model (grey).
* :func:`plot_residuals`: each contact point's lateral error against travel, one line per test, coloured by
  load (the "see where it fails" plot).
* :func:`plot_error_map`: mean horizontal distance by load level x contact point.
* :func:`plot_candidates`: diagnose's ranking (cross-validated error of each candidate against the baseline).
* :func:`plot_time_residuals`: travel lag and lateral error against time, and the residual spectrum.
* :func:`plot_deviations`: measured minus model (x1, x3) of each contact point in mm against travel (the
  overhead view's deviations at a scale where millimetres show).
* :func:`plot_error_fall`: the error after each addition, overall and per load level ("watch it fall").
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from ..atomic import write_atomic
from ..interpolate import linear
from ..paths import travel
from ..plotting import MEASURED, MODEL, overhead_axes, panel_grid, plot_traces, save_figure
from ..specimen import reference
from .compare import Comparison


def _load_colours(loads: Sequence[float]):
    import matplotlib.pyplot as plt
    cmap = plt.get_cmap("viridis")
    lo, hi = min(loads), max(loads)
    return (lambda f: cmap(0.0 if hi == lo else (f - lo) / (hi - lo))), cmap, lo, hi


def plot_overhead(cmp: Comparison, path: str | Path, title: str | None = None,
                  runs_by_test: dict | None = None) -> Path:
    """One panel per load level: measured traces (black, all repeats) and the model (grey). ``runs_by_test``
    (``{test_id: EvalResult}``, a fit with per-test parameters): each test's own model run instead of one per
    load."""
    foundation = cmp.spec.foundation or reference()[1]
    loads = sorted(cmp.runs)
    fig, axes = panel_grid(len(loads), ncols=min(4, len(loads)))
    points = [t.horizontal.reshape(-1, 2) for t in cmp.tests]
    for ax, f in zip(axes, loads):
        overhead_axes(ax, foundation, f"{f:g} N")
        mine = [t for t in cmp.tests if t.shear_force_N == f]
        for test in mine:
            plot_traces(ax, test.positions, color=MEASURED, lw=0.7, marker_start=False)
        runs = ([(runs_by_test[t.test_id].result, [t]) for t in mine] if runs_by_test
                else [(cmp.runs[f].result, mine)])
        for run, its in runs:
            if run is not None and len(run.t) > 1:
                rest = run.contact_points[0]       # the seated block, the origin of both paths
                reach = max(float(np.max(travel(t.positions, rest))) for t in its)
                keep = run.travel <= reach + 1e-9
                plot_traces(ax, run.contact_points[keep], color=MODEL, lw=1.6)
                points.append(run.contact_points[keep][:, :, ::2].reshape(-1, 2))
            elif run is not None:
                plot_traces(ax, run.contact_points, color=MODEL, lw=1.6)
    # Zoom on the traces (the intersection lines would otherwise set the scale), same window in every panel.
    allp = np.concatenate(points)
    lo, hi = allp.min(axis=0) - 0.02, allp.max(axis=0) + 0.02
    ncols = min(4, len(loads))
    nrows = int(np.ceil(len(loads) / ncols))
    for i, ax in enumerate(axes):
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        if i % ncols:
            ax.set_ylabel("")
        if i < len(loads) - ncols:
            ax.set_xlabel("")
    aspect = (hi[1] - lo[1]) / (hi[0] - lo[0])
    fig.set_size_inches(3.0 * ncols, nrows * (2.4 * aspect + 0.55) + 0.3)
    fig.subplots_adjust(hspace=0.35, wspace=0.25)
    axes[0].plot([], [], color=MEASURED, label="measured")
    axes[0].plot([], [], color=MODEL, label="model")
    axes[0].legend(fontsize=7, loc="center")
    fig.suptitle(title or f"measured (black) vs {cmp.spec.describe()} (grey)", fontsize=10)
    return save_figure(fig, path)


def plot_residuals(cmp: Comparison, path: str | Path) -> Path:
    """Lateral (x3) error, measured minus model, against CP1 travel: one panel per contact point."""
    import matplotlib.pyplot as plt
    loads = sorted(cmp.runs)
    colour, cmap, lo, hi = _load_colours(loads)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), sharey=True)
    for cp, ax in enumerate(axes):
        for d in cmp.discrepancies:
            ax.plot(d.travel_m * 100, d.lateral_mm[:, cp], color=colour(d.force_N), lw=0.8)
        ax.axhline(0.0, color="0.7", lw=0.6)
        ax.set_title(f"CP{cp + 1}", fontsize=9)
        ax.set_xlabel("CP1 travel (cm)")
    axes[0].set_ylabel("lateral error, measured - model (mm)")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(lo, hi))
    fig.colorbar(sm, ax=list(axes), label="shear load (N)", shrink=0.85)
    fig.suptitle(f"where {cmp.spec.describe()} fails: lateral error along the travel", fontsize=10)
    return save_figure(fig, path)


def plot_error_map(cmp: Comparison, path: str | Path) -> Path:
    """Mean horizontal distance (mm) by load level (rows) and contact point (columns), annotated."""
    import matplotlib.pyplot as plt
    loads, grid = cmp.cp_by_load()
    fig, ax = plt.subplots(figsize=(4.2, 0.35 * len(loads) + 1.6))
    im = ax.imshow(grid, cmap="Greys", aspect="auto", vmin=0.0)
    ax.set_xticks(range(3), [f"CP{i + 1}" for i in range(3)])
    ax.set_yticks(range(len(loads)), [f"{f:g} N" for f in loads])
    vmax = float(grid.max()) if grid.size else 1.0
    for i in range(len(loads)):
        for j in range(3):
            ax.text(j, i, f"{grid[i, j]:.1f}", ha="center", va="center", fontsize=7,
                    color="white" if grid[i, j] > 0.6 * vmax else "black")
    fig.colorbar(im, ax=ax, label="mean distance (mm)")
    ax.set_title("error by load x contact point", fontsize=9)
    return save_figure(fig, path)


def plot_candidates(report: dict, path: str | Path) -> Path:
    """Diagnose's ranking: cross-validated RMS discrepancy per candidate and per refit of a given effect (hatched),
    implausible fits marked (light, with "implausible"), the baseline, repeat scatter and expected scatter as lines."""
    import matplotlib.pyplot as plt
    rows = [(c, c["effect"]) for c in report["candidates"]]
    rows += [(c, f"{c['effect']} (refit)") for c in report.get("refit_results", [])]
    rows.sort(key=lambda r: (not math.isfinite(r[0]["cv_error_mm"]), r[0]["cv_error_mm"]))
    values = [c["cv_error_mm"] for c, _ in rows]
    fig, ax = plt.subplots(figsize=(6.5, 0.45 * len(rows) + 1.6))
    best = report.get("missing_effect")
    named = {(m["effect"], m.get("kind", "candidate")) for m in report.get("missing_effects") or []}
    if best:
        named.add((best, "candidate"))
    for i, (c, label) in enumerate(rows):
        chosen = (c["effect"], c.get("kind", "candidate")) in named
        colour = "black" if chosen else ("0.85" if not c["plausible"] else "0.6")
        ax.barh(i, c["cv_error_mm"], color=colour, hatch="//" if c.get("kind") == "refit" else None,
                edgecolor="0.3")
        if not c["plausible"]:
            ax.text(c["cv_error_mm"], i, "  implausible", va="center", fontsize=7, color="tab:red")
    ax.set_yticks(range(len(rows)), [label for _, label in rows])
    ax.invert_yaxis()
    ax.axvline(report["baseline_error_mm"], color="tab:red", lw=1, label="model as given")
    if report.get("repeat_scatter_mm"):
        ax.axvline(report["repeat_scatter_mm"], color="tab:blue", lw=1, ls="--", label="repeat scatter")
    expected = (report.get("noise") or {}).get("expected_scatter_mm")
    if expected:
        ax.axvline(expected, color="tab:green", lw=1, ls=":", label="scatter noise + specimen explain")
    ax.set_xscale("log")
    finite = [v for v in values + [report["baseline_error_mm"], report.get("repeat_scatter_mm") or math.inf]
              if v and math.isfinite(v) and v > 0]
    if finite:
        ax.set_xlim(left=0.5 * min(finite), right=4 * max(finite))
    ax.set_xlabel("cross-validated RMS discrepancy (mm)")
    # below the axes, so that it covers no bar
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.5 / (0.45 * len(rows) + 1.6) - 0.08),
              ncol=3, frameon=False)
    if len(named) > 1:
        best = " + ".join(sorted(n for n, _ in named))
    ax.set_title(f"diagnose: {report.get('verdict', '')}, {best or 'no library effect named'} "
                 f"(confidence {report.get('confidence')})", fontsize=9)
    return save_figure(fig, path)


def plot_deciding_experiments(experiments: Sequence[dict], path: str | Path) -> Path:
    """The experiment that would decide between look-alikes: per pair, the difference of their fitted models'
    predictions over the scatter of one test against load (loads where one model holds and the other slides marked
    at the top), the repeats needed for a 95 % separation written at each point."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(len(experiments), 1, figsize=(7, 3.4 * len(experiments)), squeeze=False,
                             gridspec_kw={"hspace": 0.55})
    for ax, exp in zip(axes[:, 0], experiments):
        rows = [r for r in exp["rows"] if r["ratio"] is not None]
        ax.plot([r["load_N"] for r in rows], [r["ratio"] for r in rows], "o-", color="black", lw=1)
        for r in rows:
            ax.annotate(f"n={r['repeats']}", (r["load_N"], r["ratio"]), fontsize=7, xytext=(3, 4),
                        textcoords="offset points")
        top = max([r["ratio"] for r in rows], default=1.0)
        for r in exp["rows"]:
            if r.get("holds"):
                ax.plot(r["load_N"], 1.1 * top, "v", color="tab:red")
                ax.annotate(f"{r['holds']} holds", (r["load_N"], 1.1 * top), fontsize=7, xytext=(3, -10),
                            textcoords="offset points", color="tab:red")
        best = exp.get("best")
        if best is not None:
            ax.axvline(best["load_N"], color="tab:blue", lw=0.8, ls="--", label=f"proposed: {best['load_N']:g} N")
            ax.legend(fontsize=7, loc="upper right")
        ax.set_ylabel("difference / scatter of one test", fontsize=8)
        ax.set_xlabel("shear load (N)")
        ax.set_title(f"{exp['between'][0]} vs {exp['between'][1]} (scatter {exp['scatter_mm']:.2f} mm)", fontsize=9)
    return save_figure(fig, path)


def plot_time_residuals(before: Sequence, after: Sequence | None, path: str | Path, model: str,
                        best: str | None = None) -> Path:
    """Evidence in time, for the model as given (top row) and after the best fit (bottom row, if any): travel
    lag against time, CP1's lateral error against time (one line per test, coloured by load), and the residual
    spectrum (median over tests, :func:`triplanar.workbench.evidence.residual_spectrum`)."""
    import matplotlib.pyplot as plt
    from .evidence import residual_spectrum
    sets = [(model, before)] + ([(best or "best fit", after)] if after else [])
    loads = sorted({d.force_N for d in before}) or [0.0]
    colour, cmap, lo, hi = _load_colours(loads)
    # room between the panels for each one's y-label (the spectrum's must not sit over the middle panel)
    fig, axes = plt.subplots(len(sets), 3, figsize=(14, 3.3 * len(sets)), squeeze=False,
                             gridspec_kw={"wspace": 0.42, "hspace": 0.45})
    for row, (label, found) in zip(axes, sets):
        grid = np.linspace(0.0, 60.0, 241)
        spectra = []
        for d in found:
            if d.t_s is None:
                continue
            row[0].plot(d.t_s, d.lag_mm, color=colour(d.force_N), lw=0.7)
            row[1].plot(d.t_s, d.lateral_mm[:, 0], color=colour(d.force_N), lw=0.7)
            spec = residual_spectrum(d)
            if spec is not None and np.any(spec[1] > 0):
                spectra.append(linear(grid, spec[0], spec[1] / np.median(spec[1][spec[0] >= 2.0]), right=np.nan))
        if spectra:
            row[2].semilogy(grid, np.nanmedian(np.array(spectra), axis=0), color="black", lw=1)
        row[0].set_ylabel(f"{label}\ntravel lag, model - measured (mm)", fontsize=8)
        row[1].set_ylabel("CP1 lateral error (mm)", fontsize=8)
        row[2].set_ylabel("residual power / its median\n(median over tests)", fontsize=8)
        for ax in row[:2]:
            ax.axhline(0.0, color="0.7", lw=0.6)
            ax.set_xlabel("time since the actuator began (s)")
        row[2].set_xlabel("frequency (Hz)")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(lo, hi))
    fig.colorbar(sm, ax=list(axes.ravel()), label="shear load (N)", shrink=0.85)
    fig.suptitle("residuals in time: arrival, lag, spectrum", fontsize=10)
    return save_figure(fig, path)


def plot_deviations(cmp: Comparison, path: str | Path, title: str | None = None,
                    runs_by_test: dict | None = None) -> Path:
    """Where millimetres show: each contact point's horizontal deviation from the model (measured - model, x1
    and x3 in mm) against CP1 travel, one line per test coloured by load: an overhead view of the deviations,
    relative to the model, at a scale where the post-fit agreement (tenths of a millimetre) is visible."""
    import matplotlib.pyplot as plt
    loads = sorted(cmp.runs)
    colour, cmap, lo, hi = _load_colours(loads)
    fig, axes = plt.subplots(2, 3, figsize=(12, 5.6), sharex=True, sharey="row")
    for cp in range(3):
        for d in cmp.discrepancies:
            test = next(t for t in cmp.tests if t.test_id == d.test_id)
            run = (runs_by_test[d.test_id] if runs_by_test else cmp.runs[d.force_N]).result
            if run is None or len(run.t) < 2:
                continue
            from ..paths import model_at_travel
            model = model_at_travel(run, d.travel_m)
            dx = (test.positions[:, cp, 0] - model[:, cp, 0]) * 1e3
            axes[0, cp].plot(d.travel_m * 100, dx, color=colour(d.force_N), lw=0.7)
            axes[1, cp].plot(d.travel_m * 100, d.lateral_mm[:, cp], color=colour(d.force_N), lw=0.7)
        axes[0, cp].set_title(f"CP{cp + 1}", fontsize=9)
        axes[1, cp].set_xlabel("CP1 travel (cm)")
        for ax in axes[:, cp]:
            ax.axhline(0.0, color="0.7", lw=0.6)
    axes[0, 0].set_ylabel("x1: measured - model (mm)", fontsize=8)
    axes[1, 0].set_ylabel("x3: measured - model (mm)", fontsize=8)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(lo, hi))
    fig.colorbar(sm, ax=list(axes.ravel()), label="shear load (N)", shrink=0.85)
    fig.suptitle(title or f"deviations from {cmp.spec.describe()} (mm, relative to the model)", fontsize=10)
    return save_figure(fig, path)


def plot_error_fall(steps: Sequence[dict], path: str | Path) -> Path:
    """The error after each addition: overall (black) and per load level (coloured)."""
    import matplotlib.pyplot as plt
    labels = ["model as given"] + [f"+ {s['added']}" for s in steps[1:]]
    loads = sorted(float(k) for k in steps[0]["error_by_load_mm"])
    colour, cmap, lo, hi = _load_colours(loads)
    fig, ax = plt.subplots(figsize=(max(4.5, 1.6 * len(steps)), 3.8))
    x = np.arange(len(steps))
    for f in loads:
        ax.plot(x, [s["error_by_load_mm"][f"{f:g}"] for s in steps], color=colour(f), lw=0.9, marker=".")
    ax.plot(x, [s["error_mm"] for s in steps], color="black", lw=2.2, marker="o", label="all tests")
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("RMS discrepancy (mm)")
    for xi, s in zip(x, steps):
        ax.annotate(f"{s['error_mm']:.2f}", (xi, s["error_mm"]), textcoords="offset points", xytext=(6, 4), fontsize=8)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(lo, hi))
    fig.colorbar(sm, ax=ax, label="shear load (N)")
    ax.legend(fontsize=8)
    ax.set_title("watch the error fall", fontsize=10)
    return save_figure(fig, path)


def write_json(data: dict, path: str | Path) -> Path:
    """Write JSON atomically (NaN/inf written as null)."""
    import json
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_clean(data), indent=1) + "\n"
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return path


def _clean(value):
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(float(value)) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    return value
