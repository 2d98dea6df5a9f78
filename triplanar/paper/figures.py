"""The paper's figures as overhead panels (Fig. 6 and Figs. 11-16), drawn with :mod:`triplanar.plotting`.

A figure is described by plain data (:class:`FigureSpec`: panels of traces) so it can be rendered in a
worker process; :func:`build_figure` returns the matplotlib Figure (tests inspect it), :func:`render`
builds and saves it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.ticker import MaxNLocator

from ..plotting import MEASURED, MODEL, label_contact_points, overhead_axes, panel_grid, plot_traces, save_figure
from ..specimen import Foundation


@dataclass(frozen=True)
class Trace:
    """One test's contact-point paths (n, 3, 3) in one colour."""

    positions: np.ndarray
    color: str = MODEL
    lw: float = 1.2


@dataclass(frozen=True)
class Panel:
    title: str
    traces: tuple[Trace, ...]


@dataclass(frozen=True)
class FigureSpec:
    """A grid of overhead panels: ``panels`` in rows of ``ncols``, saved as ``name`` (a PNG file name)."""

    name: str
    title: str
    panels: tuple[Panel, ...]
    ncols: int
    foundation: Foundation
    rest_positions: np.ndarray | None = None   # when given, CP1..CP3 are labelled (Fig. 6)
    size: float = 3.0
    notes: tuple[str, ...] = field(default=())


def _limits(panel: Panel, pad_fraction: float = 0.08) -> tuple[tuple[float, float], tuple[float, float]]:
    pts = np.concatenate([t.positions.reshape(-1, 3) for t in panel.traces])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = max(pad_fraction * max(hi[0] - lo[0], hi[2] - lo[2]), 1e-3)
    return (lo[0] - pad, hi[0] + pad), (lo[2] - pad, hi[2] + pad)


def build_figure(spec: FigureSpec):
    """The matplotlib Figure of ``spec`` (one axes per panel, paper-style overhead view)."""
    fig, axes = panel_grid(len(spec.panels), spec.ncols, spec.size)
    for ax, panel in zip(axes, spec.panels):
        overhead_axes(ax, spec.foundation, panel.title)
        for trace in panel.traces:
            plot_traces(ax, trace.positions, color=trace.color, lw=trace.lw)
        if spec.rest_positions is not None:
            label_contact_points(ax, spec.rest_positions)
        xlim, ylim = _limits(panel)
        ax.set_aspect("equal", adjustable="box")  # keep these limits; the panel box takes the aspect
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.yaxis.set_major_locator(MaxNLocator(5))
        ax.tick_params(labelsize=7)
    fig.suptitle(spec.title, fontsize=10)
    if spec.notes:
        fig.text(0.5, -0.01, "\n".join(spec.notes), ha="center", va="top", fontsize=8)
    fig.tight_layout()
    return fig


def render(spec: FigureSpec, out_dir: str | Path) -> Path:
    """Build ``spec`` and write it to ``out_dir / spec.name`` (atomic PNG)."""
    return save_figure(build_figure(spec), Path(out_dir) / spec.name)


def measured_trace(positions: np.ndarray) -> Trace:
    return Trace(positions, MEASURED, 0.8)


def model_trace(positions: np.ndarray) -> Trace:
    return Trace(positions, MODEL, 1.6)
