"""``evaluate``'s summary has the mean return with its interval, and its plot reads below 1 mm and shows failures."""

from __future__ import annotations

import csv
import math
from types import SimpleNamespace

import numpy as np

from experiments import bench_plots
from experiments.evaluate import evaluate, write
from experiments.stats import row_stats


def test_summary_has_the_mean_return_with_its_interval(tmp_path):
    result = evaluate("steel_tip", n=3, progress=False)
    returns = [o.episode_return for seed in result.outcomes for o in seed]
    s = result.stats
    assert s["mean_return"] == np.mean(returns) and s["return_low"] <= s["mean_return"] <= s["return_high"]
    write(result, tmp_path)
    with open(tmp_path / "heldout.csv", newline="") as f:
        row = next(csv.DictReader(f))
    assert math.isclose(float(row["mean_return"]), s["mean_return"], rel_tol=1e-3)


def _row(errors: list[float], failures: int):
    outcomes = [[SimpleNamespace(mimicry_error_mm=e, success=True) for e in errors]
                + [SimpleNamespace(mimicry_error_mm=math.nan, success=False) for _ in range(failures)]]
    table = np.array([[o.mimicry_error_mm for o in outcomes[0]]])
    return ("below 1 mm", "heldout", row_stats(table, np.isfinite(table), 10.0), outcomes)


def test_the_error_axis_labels_values_below_one_mm_and_failures_are_drawn(tmp_path, monkeypatch):
    figures = []
    monkeypatch.setattr(bench_plots, "save_figure", lambda fig, path, dpi: figures.append(fig))
    bench_plots.rows_plot(tmp_path / "p.png", [_row([0.06, 0.12, 0.3, 0.45], failures=3)], "test")
    ax = figures[0].axes[0]
    figures[0].canvas.draw()
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
    assert {"0.1", "0.2", "0.5", "1"} <= set(labels)      # a controller under 1 mm reads (it read only "1.0")
    crosses = [c for c in ax.collections if len(c.get_offsets()) == 3 and c.get_label() == "failed episode"]
    assert len(crosses) == 1 and np.all(crosses[0].get_offsets()[:, 0] > 0.45)
