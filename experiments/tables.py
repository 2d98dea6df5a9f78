"""The bench study's and ``triplanar evaluate``'s output files: written to a temporary name and renamed (complete
or not at all), and the columns of a statistics row (:func:`experiments.stats.row_stats`)."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

# The statistics columns of every row (held-out, nominal, stress, design sweep), after the row's own labels.
STATS_FIELDS = ("n_benches", "n_seeds", "n_episodes", "success_rate", "success_low", "success_high",
                "mimicry_error_mm", "error_low_mm", "error_high_mm", "cvar10_mm", "score", "score_low", "score_high",
                "seed_errors_mm", "seed_scores_mm")


def write_atomic(path: Path, write: Callable[[Path], Any]) -> None:
    """``write(tmp)`` then rename ``tmp`` to ``path``; a failed write leaves no file behind."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> None:
    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            writer.writerows(rows)
    write_atomic(path, write)


def write_json(path: Path, data: Any) -> None:
    write_atomic(path, lambda p: p.write_text(json.dumps(data, indent=2, default=float) + "\n"))


def fmt(value: Any) -> Any:
    """A value for a CSV cell: floats to 4 significant digits, lists space-separated."""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple)):
        return " ".join(str(fmt(v)) for v in value)
    return value


def stats_cells(stats: dict[str, Any]) -> list[Any]:
    """The :data:`STATS_FIELDS` cells of one row."""
    return [fmt(stats[k]) for k in STATS_FIELDS]


EPISODE_FIELDS = ("controller", "bench_set", "seed", "index", "load_N", "success", "reason", "mimicry_error_mm",
                  "travel_m", "return", "steps")


def episode_cells(outcome: Any, seed: int) -> list[Any]:
    o = outcome
    return [o.controller, o.bench_set, seed, o.index, f"{o.load_N:.3f}", int(o.success), o.reason,
            f"{o.mimicry_error_mm:.4f}", f"{o.travel_m:.5f}", f"{o.episode_return:.4f}", o.steps]
