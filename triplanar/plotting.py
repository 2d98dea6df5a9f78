"""Overhead views in the paper's style (Fig. 6): x1 to the right, x3 up, equal axes, the foundation
planes' lines of intersection in light grey, contact-point traces as lines.

Every figure-making function in the project draws through these helpers, so all plots agree.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")  # files only; no display needed (CI, servers)
import matplotlib.pyplot as plt
import numpy as np

from .atomic import write_atomic
from .specimen import Foundation

MEASURED = "black"
MODEL = "0.6"  # grey, as in the paper


def intersection_lines(foundation: Foundation, extent: float = 0.5) -> list[np.ndarray]:
    """Overhead (x1, x3) segments of the three planes' pairwise intersection lines, from the origin
    outward, on the part that bounds the upper envelope (where the two planes are the top ones)."""
    normals = foundation.normals
    segments = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        k = 3 - i - j
        direction = np.cross(normals[i], normals[j])
        for sign in (1.0, -1.0):
            d = sign * direction / np.linalg.norm(direction[[0, 2]])
            point = d * extent
            h_top = -(normals[i][0] * point[0] + normals[i][2] * point[2]) / normals[i][1]
            h_other = -(normals[k][0] * point[0] + normals[k][2] * point[2]) / normals[k][1]
            if h_top >= h_other - 1e-12:
                segments.append(np.array([[0.0, 0.0], [point[0], point[2]]]))
    return segments


def overhead_axes(ax: plt.Axes, foundation: Foundation, title: str | None = None) -> None:
    """Prepare an overhead panel: intersection lines, labels, equal scaling."""
    for seg in intersection_lines(foundation):
        ax.plot(seg[:, 0], seg[:, 1], color="0.85", lw=0.8, zorder=0)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x1 (m)")
    ax.set_ylabel("x3 (m)")
    if title:
        ax.set_title(title, fontsize=9)


def plot_traces(ax: plt.Axes, positions: np.ndarray, color: str = MODEL, lw: float = 1.2,
                label: str | None = None, marker_start: bool = True) -> None:
    """Draw the three contact points' overhead traces; ``positions`` is (n, 3, 3)."""
    for cp in range(3):
        ax.plot(positions[:, cp, 0], positions[:, cp, 2], color=color, lw=lw, label=label if cp == 0 else None)
        if marker_start:
            ax.plot(positions[0, cp, 0], positions[0, cp, 2], "o", color=color, ms=2.5)


def label_contact_points(ax: plt.Axes, rest_positions: np.ndarray) -> None:
    for cp in range(3):
        ax.annotate(f"CP{cp + 1}", (rest_positions[cp, 0], rest_positions[cp, 2]), textcoords="offset points",
                    xytext=(-18, 4), fontsize=7)


def panel_grid(n: int, ncols: int = 4, size: float = 3.0) -> tuple[plt.Figure, Sequence[plt.Axes]]:
    """A figure with ``n`` panels in rows of ``ncols`` (extra axes hidden)."""
    nrows = int(np.ceil(n / ncols))
    fig, axes = plt.subplots(nrows, ncols, figsize=(size * ncols, size * nrows), squeeze=False)
    flat = axes.ravel()
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def save_figure(fig: plt.Figure, path: str | Path, dpi: int = 120) -> Path:
    """Write a PNG atomically (:func:`triplanar.atomic.write_atomic`; the temporary keeps the ``.png`` suffix that
    matplotlib reads the format from) and close the figure, also when writing fails."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi, bbox_inches="tight"))
    finally:
        plt.close(fig)
    return path
