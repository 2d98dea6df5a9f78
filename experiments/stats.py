"""Statistics of the bench study's rows: a controller's episodes on a set of benches, for one or more seeds.

A row's episodes form a table ``(seeds, benches)``: a seed is a training seed for a learned controller, a
sensor-noise replicate for a scripted one; a bench is one held-out (or stress, nominal) specimen. Both vary, so
the interval of the mean is a **hierarchical bootstrap**: resample the seeds with replacement, then, for each
resample, the benches with replacement (the same bench resample for every seed drawn, since every seed runs on the
same benches), and take the statistic of the resampled table. With one seed it is the ordinary bootstrap over
benches.

* :func:`mean_error_ci`: mean mimicry error over successful episodes, with its 95 % percentile interval;
* :func:`cvar`: the mean of the worst decile (CVaR 10 %) of the errors of successful episodes;
* :func:`wilson`: Wilson's score interval of a success rate (it stays inside [0, 1] and is not empty at 0 or n
  successes, unlike the normal approximation);
* :func:`success_ci`: the success rate's interval, the union of Wilson's (over all episodes: not empty when every
  episode succeeded, where a bootstrap collapses to a point) and the hierarchical bootstrap's (which sees that
  seeds differ; Wilson treats every episode as independent);
* :func:`row_stats`: all of the above for one row, plus the per-seed means (the seeds' spread);
* :func:`return_stats`: the mean episode return with its interval (the same bootstrap).

Failed episodes have a NaN error and are never averaged into an error; they count in the success rate and in the
score of :mod:`agents.heldout`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.stats import norm

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 17_017
CVAR_FRACTION = 0.10


def _table(errors: Any) -> np.ndarray:
    table = np.asarray(errors, dtype=float)
    if table.ndim == 1:
        table = table[None, :]
    if table.ndim != 2 or table.size == 0:
        raise ValueError(f"errors must be a non-empty (seeds, benches) table, got shape {np.shape(errors)}")
    return table


def _nanmean_rows(x: np.ndarray) -> np.ndarray:
    """Mean over the last axis ignoring NaN; NaN where a row has no finite value (without numpy's warning)."""
    finite = np.isfinite(x)
    count = finite.sum(axis=-1)
    total = np.where(finite, x, 0.0).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def hierarchical_resamples(n_seeds: int, n_benches: int, resamples: int = BOOTSTRAP_RESAMPLES,
                           seed: int = BOOTSTRAP_SEED) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays ``(resamples, n_seeds)`` and ``(resamples, n_benches)``: seeds first, then benches."""
    rng = np.random.default_rng(seed)
    return rng.integers(0, n_seeds, (resamples, n_seeds)), rng.integers(0, n_benches, (resamples, n_benches))


def bootstrap_ci(table: Any, statistic, *, confidence: float = CONFIDENCE, resamples: int = BOOTSTRAP_RESAMPLES,
                 seed: int = BOOTSTRAP_SEED) -> tuple[float, float, float]:
    """``(statistic(table), low, high)``: the percentile interval of ``statistic`` (a function of a
    ``(seeds, benches)`` array, NaN allowed) over hierarchical resamples; resamples where it is NaN are dropped."""
    table = _table(table)
    point = float(statistic(table))
    seeds_ix, benches_ix = hierarchical_resamples(*table.shape, resamples=resamples, seed=seed)
    values = np.array([statistic(table[np.ix_(s, b)]) for s, b in zip(seeds_ix, benches_ix)])
    values = values[np.isfinite(values)]
    if not len(values):
        return point, math.nan, math.nan
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(values, [alpha, 1.0 - alpha])
    return point, float(low), float(high)


def mean_of_successes(table: np.ndarray) -> float:
    """Mean error over all successful episodes of the table (NaN: failures), pooled over seeds."""
    finite = table[np.isfinite(table)]
    return float(finite.mean()) if finite.size else math.nan


def mean_error_ci(errors: Any, **kwargs: Any) -> tuple[float, float, float]:
    """Mean error over successful episodes and its hierarchical bootstrap interval."""
    return bootstrap_ci(errors, mean_of_successes, **kwargs)


def cvar(errors: Any, fraction: float = CVAR_FRACTION) -> float:
    """The mean of the worst ``fraction`` of the successful episodes' errors (at least one episode); NaN if none
    succeeded."""
    values = np.sort(np.asarray(errors, dtype=float).ravel())
    values = values[np.isfinite(values)]
    if not values.size:
        return math.nan
    k = max(1, math.ceil(fraction * values.size - 1e-9))
    return float(values[-k:].mean())


def wilson(successes: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson's score interval of a binomial proportion ``successes / n``."""
    if n <= 0:
        return math.nan, math.nan
    z = float(norm.ppf(0.5 + confidence / 2.0))
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def success_ci(success: Any, **kwargs: Any) -> tuple[float, float, float]:
    """``(rate, low, high)`` of a ``(seeds, benches)`` table of successes: the union of Wilson's interval and the
    hierarchical bootstrap's."""
    table = _table(np.asarray(success, dtype=float))
    rate, b_low, b_high = bootstrap_ci(table, lambda t: float(t.mean()), **kwargs)
    w_low, w_high = wilson(int(table.sum()), int(table.size))
    return rate, min(w_low, b_low), max(w_high, b_high)


def return_stats(returns: Any) -> dict[str, float]:
    """``mean_return`` of a ``(seeds, benches)`` table of episode returns, with its hierarchical bootstrap interval
    (``return_low``, ``return_high``): the figure an RL user compares first."""
    mean, low, high = bootstrap_ci(_table(returns), lambda t: float(t.mean()))
    return {"mean_return": mean, "return_low": low, "return_high": high}


def row_stats(errors: Any, success: Any, failure_score_mm: float) -> dict[str, Any]:
    """Everything a table row gives, from ``errors`` (seeds x benches, mm, NaN where failed) and ``success``
    (the same shape, bool): episodes, seeds, benches, success rate with its interval (:func:`success_ci`), mean error over
    successes with its hierarchical bootstrap interval, CVaR 10 %, the score (failure = ``failure_score_mm``)
    with its interval, and the per-seed means of error and score (``seed_errors_mm``, ``seed_scores_mm``)."""
    table = _table(errors)
    ok = np.asarray(success, dtype=bool).reshape(table.shape)
    if np.any(np.isfinite(table) != ok):
        raise ValueError("errors must be finite exactly where success is true")
    n, k = int(ok.size), int(ok.sum())
    mean, low, high = mean_error_ci(table)
    scores = np.where(ok, table, failure_score_mm)
    score, score_low, score_high = bootstrap_ci(scores, lambda t: float(t.mean()))
    _, s_low, s_high = success_ci(ok)
    return {"n_episodes": n, "n_seeds": table.shape[0], "n_benches": table.shape[1],
            "success_rate": k / n, "success_low": s_low, "success_high": s_high,
            "mimicry_error_mm": mean, "error_low_mm": low, "error_high_mm": high,
            "cvar10_mm": cvar(table), "score": score, "score_low": score_low, "score_high": score_high,
            "seed_errors_mm": [float(v) for v in _nanmean_rows(table)],
            "seed_scores_mm": [float(v) for v in scores.mean(axis=1)]}


def indistinguishable(rows: list[dict[str, Any]], low: str = "error_low_mm", high: str = "error_high_mm") -> list[int]:
    """Indices of the rows whose interval overlaps the interval of the row with the lowest upper end: the rows
    that cannot be told apart from the best by these intervals."""
    finite = [i for i, r in enumerate(rows) if math.isfinite(r[high])]
    if not finite:
        return []
    best = min(finite, key=lambda i: rows[i][high])
    return [i for i in finite if rows[i][low] <= rows[best][high]]
