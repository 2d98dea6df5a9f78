"""The compiled per-test terms of the discrepancy are numpy's arithmetic to the last bit: numpy's pairwise order for
whole-array sums, row order for the per-column means, and the same element-wise operations (the reports and every
fit's path depend on these bits)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from triplanar.workbench.discrepancy_kernel import MM, pairwise_sum, per_test_terms


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 15, 16, 127, 128, 129, 136, 255, 256, 257, 1000, 1031, 9000, 20011])
def test_pairwise_sum_is_numpys_sum_bit_for_bit(n: int) -> None:
    rng = np.random.default_rng(n)
    values = (rng.normal(size=n) * 10.0 ** rng.uniform(-6, 6, size=n)) ** 2
    assert pairwise_sum(values, 0, n) == np.sum(values)
    if n > 12:          # a slice inside a longer array
        assert pairwise_sum(values, 5, n - 9) == np.sum(values[5:n - 4])


def _numpy_terms(positions: np.ndarray, model3: np.ndarray, lag: np.ndarray | None):
    """The numpy expressions the compiled terms replace (as the comparison wrote them before)."""
    n = len(positions)
    d = (positions[:, :, ::2] - model3[:, :, ::2]) * MM
    dist = np.hypot(d[..., 0], d[..., 1])
    dv = (positions[:, :, 1] - model3[:, :, 1]) * MM
    dv = np.where(np.isfinite(dv), dv, 0.0)
    groups = 4 if lag is not None else 3
    sq = (float(np.sum(dist**2)) + float(np.sum(dv**2))) / n + (float(np.sum(lag**2)) / n if lag is not None else 0.0)
    scale = 1.0 / math.sqrt(n * groups)
    parts = [d.reshape(n, 6) * scale, dv * scale] + ([lag[:, None] * scale] if lag is not None else [])
    residuals = np.concatenate([p.ravel() for p in parts])
    lag_rms = float(np.sqrt(np.mean(lag**2))) if lag is not None else math.nan
    return d, dist, dv, residuals, math.sqrt(sq / groups), dist.mean(axis=0), lag_rms


@pytest.mark.parametrize("n", [1, 5, 43, 130, 700])
@pytest.mark.parametrize("timed", [True, False])
@pytest.mark.parametrize("vertical", ["all", "none", "some"])
def test_terms_are_the_numpy_expressions_bit_for_bit(n: int, timed: bool, vertical: str) -> None:
    rng = np.random.default_rng(n + 7 * timed)
    model3 = rng.normal(size=(n, 3, 3)) * 0.05
    positions = model3 + rng.normal(size=(n, 3, 3)) * 10.0 ** rng.uniform(-7, -2, size=(n, 3, 3))
    if vertical == "none":
        positions[:, :, 1] = np.nan
    elif vertical == "some":
        positions[::3, 1, 1] = np.nan
    positions.setflags(write=False)         # (as a measured test's are: the signature the workbench compiles)
    lag = rng.normal(size=n) * 0.3 if timed else None
    got = per_test_terms(positions, model3, lag if timed else np.zeros(0), timed)
    want = _numpy_terms(positions, model3, lag)
    for name, a, b in zip(("d", "dist", "dv", "residuals", "error", "mean", "lag_rms"), got, want):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), name
