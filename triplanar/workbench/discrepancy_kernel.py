"""The per-test arithmetic of :mod:`triplanar.workbench.discrepancy`, compiled: one call per test instead of some
twenty small numpy operations (a fit compares every test at every parameter vector it tries, so this ran about
30,000 times in one ``diagnose`` of the shipped data, at about 0.2 ms each).

It computes exactly what the numpy expressions it replaces computed, to the last bit: the element-wise terms
by the same operations in the same order, the sums over a whole array in numpy's own pairwise order
(:func:`pairwise_sum`: numpy's ``pairwise_sum`` for contiguous doubles) and the per-column means in numpy's order
along the first axis (row by row). ``tests/triplanar/workbench/test_discrepancy_kernel.py`` checks both against
numpy on arrays of every size class.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MM = 1e3
#: numpy's pairwise summation: blocks of at most this many elements are summed in eight interleaved partial sums
_BLOCK = 128


@njit(cache=True, error_model="numpy")
def _block_sum(a: np.ndarray, start: int, n: int) -> float:
    """numpy's sum of at most 128 contiguous doubles: fewer than 8 one by one, else eight interleaved partial sums."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[start + i]
        return res
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = 8
    while i < n - n % 8:
        k = start + i
        r0 += a[k]
        r1 += a[k + 1]
        r2 += a[k + 2]
        r3 += a[k + 3]
        r4 += a[k + 4]
        r5 += a[k + 5]
        r6 += a[k + 6]
        r7 += a[k + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[start + i]
        i += 1
    return res


# (its signature given: called with a literal 0 from compiled code and with integers from Python, it compiles once)
@njit("float64(float64[::1], int64, int64)", cache=True, error_model="numpy")
def pairwise_sum(a: np.ndarray, start: int, n: int) -> float:
    """Sum of ``a[start:start + n]`` (1-d, contiguous) in numpy's order (``np.sum`` of a contiguous array): blocks of
    at most 128 by :func:`_block_sum`, longer runs split in halves at a multiple of 8 and the halves' sums added.
    numpy recurses; this walks the same tree with an explicit stack (numba's cache mishandles recursive functions)."""
    if n <= _BLOCK:
        return _block_sum(a, start, n)
    starts = np.empty(64, np.int64)
    sizes = np.empty(64, np.int64)
    phases = np.zeros(64, np.int64)     # 0: left half next, 1: right half next, 2: both summed
    sums = np.empty(64)
    top, kept = 1, 0
    starts[0], sizes[0] = start, n
    while top > 0:
        s, m = starts[top - 1], sizes[top - 1]
        if m <= _BLOCK:
            sums[kept] = _block_sum(a, s, m)
            kept += 1
            top -= 1
            continue
        half = m // 2
        half -= half % 8
        if phases[top - 1] == 2:
            sums[kept - 2] = sums[kept - 2] + sums[kept - 1]
            kept -= 1
            top -= 1
            continue
        right = phases[top - 1] == 1
        phases[top - 1] += 1
        starts[top] = s + half if right else s
        sizes[top] = m - half if right else half
        phases[top] = 0
        top += 1
    return sums[0]


@njit(cache=True, error_model="numpy")
def per_test_terms(positions: np.ndarray, model3: np.ndarray, lag: np.ndarray, timed: bool):
    """One test's discrepancy terms (mm), as :func:`triplanar.workbench.discrepancy._compare` defines them.

    Args:
        positions: (n, 3, 3) measured contact points (m); NaN in x2 where the file has no vertical.
        model3: (n, 3, 3) the model at the same travels (m).
        lag: (n,) CP1's modelled minus measured travel at each instant (mm), read only when ``timed``.

    Returns ``(d, dist, dv, residuals, error_mm, mean_mm, lag_rms_mm)``: the horizontal differences (n, 3, 2), their
    lengths (n, 3), the vertical differences (n, 3; 0 where not measured), the fit's residual vector (module
    :mod:`~triplanar.workbench.discrepancy`'s layout), the RMS discrepancy, the mean horizontal distance per
    contact point (3,) and the RMS travel lag (NaN when not ``timed``).
    """
    n = positions.shape[0]
    groups = 4 if timed else 3
    d = np.empty((n, 3, 2))
    dist = np.empty((n, 3))
    dv = np.empty((n, 3))
    dist2 = np.empty(n * 3)
    dv2 = np.empty(n * 3)
    for i in range(n):
        for c in range(3):
            d0 = (positions[i, c, 0] - model3[i, c, 0]) * MM
            d1 = (positions[i, c, 2] - model3[i, c, 2]) * MM
            d[i, c, 0] = d0
            d[i, c, 1] = d1
            r = np.hypot(d0, d1)
            dist[i, c] = r
            dist2[3 * i + c] = r * r
            v = (positions[i, c, 1] - model3[i, c, 1]) * MM
            v = v if np.isfinite(v) else 0.0
            dv[i, c] = v
            dv2[3 * i + c] = v * v
    sq = (pairwise_sum(dist2, 0, 3 * n) + pairwise_sum(dv2, 0, 3 * n)) / n
    lag_rms = math.nan
    if timed:
        lag2 = np.empty(n)
        for i in range(n):
            lag2[i] = lag[i] * lag[i]
        lag_mean = pairwise_sum(lag2, 0, n) / n
        sq = sq + lag_mean
        lag_rms = math.sqrt(lag_mean)
    else:
        sq = sq + 0.0
    error = math.sqrt(sq / groups)
    scale = 1.0 / math.sqrt(n * groups)
    residuals = np.empty(n * (10 if timed else 9))
    for i in range(n):
        for c in range(3):
            residuals[6 * i + 2 * c] = d[i, c, 0] * scale
            residuals[6 * i + 2 * c + 1] = d[i, c, 1] * scale
            residuals[6 * n + 3 * i + c] = dv[i, c] * scale
        if timed:
            residuals[9 * n + i] = lag[i] * scale
    mean = np.zeros(3)
    for i in range(n):
        for c in range(3):
            mean[c] += dist[i, c]
    for c in range(3):
        mean[c] /= n
    return d, dist, dv, residuals, error, mean, lag_rms
