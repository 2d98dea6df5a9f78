"""experiments.stats on cases with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from experiments import stats


def test_wilson_matches_the_published_intervals():
    # Wilson (1927) score interval, 95 %: 8 of 10 -> 0.490-0.943; 0 of 10 -> 0-0.278; 10 of 10 -> 0.722-1.
    assert stats.wilson(8, 10) == pytest.approx((0.4902, 0.9433), abs=1e-4)
    assert stats.wilson(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert stats.wilson(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)


def test_cvar_is_the_mean_of_the_worst_decile_of_successes():
    errors = np.arange(1.0, 101.0)
    assert stats.cvar(errors) == pytest.approx(95.5)        # mean of 91..100
    with_failures = np.concatenate([errors, [np.nan] * 7])  # failures are not errors
    assert stats.cvar(with_failures) == pytest.approx(95.5)
    assert stats.cvar([2.0, 1.0, 3.0]) == 3.0               # at least one episode
    assert math.isnan(stats.cvar([np.nan, np.nan]))


def test_bootstrap_over_benches_matches_the_standard_error():
    rng = np.random.default_rng(1)
    errors = rng.normal(1.0, 0.5, 400)
    mean, low, high = stats.mean_error_ci(errors)
    half = 1.959964 * errors.std() / math.sqrt(errors.size)
    assert mean == pytest.approx(errors.mean())
    assert (high - low) / 2 == pytest.approx(half, rel=0.1)
    assert low < mean < high


def test_hierarchical_bootstrap_resamples_seeds_and_benches():
    # additive table: seed effect a_s + bench effect c_b. A resample's mean is mean(a*) + mean(c*), independent,
    # so its variance is var(a)/S + var(c)/B (plug-in variances).
    rng = np.random.default_rng(2)
    a, c = rng.normal(0.0, 0.3, 30), rng.normal(1.0, 0.5, 60)
    table = a[:, None] + c[None, :]
    _, low, high = stats.mean_error_ci(table)
    sd = math.sqrt(a.var() / a.size + c.var() / c.size)
    assert (high - low) / 2 == pytest.approx(1.959964 * sd, rel=0.1)
    # seeds alone differ: an interval over benches only would have no width
    only_seeds = np.repeat(a[:, None], 60, axis=1)
    _, low, high = stats.mean_error_ci(only_seeds)
    assert (high - low) / 2 == pytest.approx(1.959964 * a.std() / math.sqrt(a.size), rel=0.1)


def test_constant_errors_give_a_point_interval():
    assert stats.mean_error_ci(np.full((3, 5), 0.7)) == pytest.approx((0.7, 0.7, 0.7))


def test_row_stats_counts_failures_only_in_success_and_score():
    errors = np.array([[1.0, np.nan, 3.0, 2.0], [2.0, 2.0, np.nan, 2.0]])
    row = stats.row_stats(errors, np.isfinite(errors), failure_score_mm=10.0)
    assert row["n_episodes"] == 8 and row["n_seeds"] == 2 and row["n_benches"] == 4
    assert row["success_rate"] == 0.75
    assert row["mimicry_error_mm"] == pytest.approx(2.0)
    assert row["score"] == pytest.approx((12.0 + 20.0) / 8)
    assert row["seed_errors_mm"] == pytest.approx([2.0, 2.0])
    assert row["seed_scores_mm"] == pytest.approx([4.0, 4.0])
    assert row["success_low"] < 0.75 < row["success_high"]
    assert row["error_low_mm"] <= 2.0 <= row["error_high_mm"]
    with pytest.raises(ValueError, match="finite exactly where success"):
        stats.row_stats(errors, np.ones_like(errors, dtype=bool), 10.0)


def test_indistinguishable_rows_overlap_the_best_interval():
    rows = [{"error_low_mm": 0.8, "error_high_mm": 1.2}, {"error_low_mm": 0.5, "error_high_mm": 0.9},
            {"error_low_mm": 0.95, "error_high_mm": 1.4}, {"error_low_mm": 0.85, "error_high_mm": 1.0}]
    assert stats.indistinguishable(rows) == [0, 1, 3]


def test_success_interval_widens_when_seeds_disagree():
    # 10 seeds x 20 benches, 150 successes either way: spread evenly over seeds and benches (every seed 15 of 20,
    # every bench 7 or 8 of 10), the interval is close to Wilson's (it always contains it); concentrated (half the
    # seeds always succeed), the seeds' clustering makes it several times wider.
    s, b = np.meshgrid(np.arange(10), np.arange(20), indexing="ij")
    even = (b + 2 * s) % 20 < 15
    clustered = np.zeros((10, 20), dtype=bool)
    clustered[:5] = True
    clustered[5:, :10] = True
    w_low, w_high = stats.wilson(150, 200)
    rate, low, high = stats.success_ci(even)
    assert rate == 0.75 and low <= w_low and high >= w_high and high - low < 1.3 * (w_high - w_low)
    rate, low, high = stats.success_ci(clustered)
    assert rate == 0.75 and high - low > 2.5 * (w_high - w_low)
