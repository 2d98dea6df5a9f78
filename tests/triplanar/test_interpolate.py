"""The one cubic Hermite interpolator (triplanar/interpolate.py) and ``SimulationResult.sol``, the dense output."""

from __future__ import annotations

import math

import numpy as np
import pytest

from triplanar import kernel as K, paper_model, simulate
from triplanar.interpolate import CubicHermite, distinct_times, linear


def test_hermite_reproduces_a_cubic_exactly_and_its_derivative() -> None:
    t = np.array([0.0, 0.3, 0.5, 1.2])

    def f(x: np.ndarray) -> np.ndarray:
        return 2 * x**3 - x**2 + 0.5 * x - 1

    def df(x: np.ndarray) -> np.ndarray:
        return 6 * x**2 - 2 * x + 0.5

    spline = CubicHermite(t, f(t), df(t))
    tq = np.linspace(0.0, 1.2, 37)
    value, slope = spline.evaluate(tq, derivative=True)
    np.testing.assert_allclose(value, f(tq), atol=1e-13)
    np.testing.assert_allclose(slope, df(tq), atol=1e-12)
    assert spline(0.7) == pytest.approx(f(0.7), abs=1e-13)
    assert np.ndim(spline(0.7)) == 0


def test_hermite_rows_first_shapes_clamping_and_repeated_times() -> None:
    t = np.array([0.0, 1.0, 1.0, 2.0])
    values = np.arange(4 * 6, dtype=float).reshape(4, 3, 2)
    spline = CubicHermite(t[distinct_times(t)], values[distinct_times(t)], np.zeros((3, 3, 2)))
    assert distinct_times(t).tolist() == [True, False, True, True]
    assert spline(np.array([0.5, 1.5])).shape == (2, 3, 2)
    np.testing.assert_array_equal(spline(1.0), values[2])   # a repeated time keeps its last row
    np.testing.assert_array_equal(spline(-5.0), values[0])  # clamped, no extrapolation
    np.testing.assert_array_equal(spline(9.0), values[3])
    np.testing.assert_array_equal(CubicHermite([0.0], values[:1], values[:1])(np.array([3.0, 4.0])),
                                  values[[0, 0]])
    with pytest.raises(ValueError, match="non-decreasing"):
        CubicHermite(np.array([1.0, 0.0]), np.zeros(2), np.zeros(2))


@pytest.mark.parametrize("case, force", [("A", 40.0), ("B", 23.0)])
def test_sol_is_exact_at_the_rows_and_close_to_a_tighter_run_between_them(case: str, force: float) -> None:
    """B at 23 N pivots about a sticking CP3 that later slips slowly: the modes the derivative needs."""
    coarse = simulate(paper_model(case, force), rtol=1e-6, atol=1e-9)
    tight = simulate(paper_model(case, force), rtol=1e-11, atol=1e-14)
    np.testing.assert_array_equal(coarse.sol(coarse.t), coarse.y)
    assert coarse.sol(float(coarse.t[3])).shape == (K.N_STATE,)
    inside = tight.t <= coarse.t[-1]
    between = coarse.sol(tight.t[inside])
    linear = np.stack([np.interp(tight.t[inside], coarse.t, coarse.y[:, j]) for j in range(K.N_STATE)], axis=1)
    truth = tight.y[inside]
    for part, bound in ((slice(K.S_R, K.S_R + 3), 2e-7), (slice(K.S_V, K.S_V + 3), 2e-5)):
        error = np.abs(between[:, part] - truth[:, part]).max()
        assert error < bound
        assert error < 0.1 * np.abs(linear[:, part] - truth[:, part]).max()  # it is not just linear


def test_dydt_is_the_right_hand_side_the_run_went_on_with() -> None:
    """B at 23 N pivots about a sticking CP3: each row's recorded derivative is the kernel's right-hand side with the
    modes in force there (so where a contact sticks, its velocity's derivative keeps it at rest)."""
    result = simulate(paper_model("B", 23.0), rtol=1e-6, atol=1e-9)
    stuck_rows = result.aux[:, K.A_STICK] != -1
    assert stuck_rows.any() and not stuck_rows.all()
    np.testing.assert_array_equal(result.dydt[:, K.S_R:K.S_R + 3], result.y[:, K.S_V:K.S_V + 3])
    # a row where every contact slides: the derivative is the right-hand side with all-sliding modes
    k = int(np.flatnonzero(~stuck_rows & (np.linalg.norm(result.contact_velocities, axis=2).min(axis=1) > 1e-3))[-1])
    dy, aux = np.empty(K.N_STATE), np.empty(K.N_AUX)
    K.rhs(float(result.t[k]), result.y[k].copy(), result.model.kernel_params(), K.sliding_modes(), dy, aux)
    np.testing.assert_allclose(result.dydt[k], dy, rtol=1e-12, atol=1e-12)
    # where CP3 sticks its velocity stays (numerically) zero: the recorded acceleration of that point is ~0
    j = int(np.flatnonzero(stuck_rows)[len(np.flatnonzero(stuck_rows)) // 2])
    stuck = int(np.argmin(np.linalg.norm(result.contact_velocities[j], axis=1)))
    arm = result.contact_points[j, stuck] - result.mass_centre[j]
    omega = result.y[j, K.S_W:K.S_W + 3]
    a_point = (result.dydt[j, K.S_V:K.S_V + 3] + np.cross(result.dydt[j, K.S_W:K.S_W + 3], arm)
               + np.cross(omega, np.cross(omega, arm)))
    assert np.linalg.norm(a_point) < 1e-6 * np.linalg.norm(result.dydt[j, K.S_V:K.S_V + 3])


def test_linear_interpolates_between_rows_and_holds_or_marks_the_ends() -> None:
    x, y = np.array([0.0, 1.0, 3.0]), np.array([2.0, 4.0, 0.0])
    assert np.array_equal(linear(np.array([-1.0, 0.5, 2.0, 5.0]), x, y), [2.0, 3.0, 2.0, 0.0])
    beyond = linear(np.array([2.0, 4.0]), x, y, right=np.nan)
    assert beyond[0] == 2.0 and np.isnan(beyond[1])
    assert linear(1.5, x, y) == 3.0


def _array_form(t, y, dy, tq, derivative):
    """The interpolant as NumPy array operations (what the compiled loop replaced): its reference, to the bit.

    The cube is the C library's ``pow``, as in the compiled loop: NumPy's ``power`` is the same function only on a
    processor without AVX-512 (with it, NumPy computes powers with its own SIMD routines, which differ in the last
    bit for about one argument in twenty)."""
    i = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
    shape = (-1,) + (1,) * (y.ndim - 1)
    h = (t[i + 1] - t[i]).reshape(shape)
    u = (tq - t[i]).reshape(shape) / h
    u2, u3 = u**2, np.frompyfunc(math.pow, 2, 1)(u, 3.0).astype(float)
    h00, h10, h01, h11 = 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2
    pos = h00 * y[i] + h10 * h * dy[i] + h01 * y[i + 1] + h11 * h * dy[i + 1]
    dh00, dh10, dh01, dh11 = 6 * u2 - 6 * u, 3 * u2 - 4 * u + 1, -6 * u2 + 6 * u, 3 * u2 - 2 * u
    vel = (dh00 * y[i] + dh10 * h * dy[i] + dh01 * y[i + 1] + dh11 * h * dy[i + 1]) / h
    return pos, vel


@pytest.mark.parametrize("shape", [(), (3, 3), (4,)])
def test_the_compiled_interpolant_is_the_array_form_to_the_bit(shape) -> None:
    rng = np.random.default_rng(7)
    for n in (2, 3, 17, 60):
        t = np.sort(rng.random(n))
        if n > 3:
            t[2] = t[1]                        # an event row: a repeated time inside the span
        y = rng.standard_normal((n, *shape)) * 10.0 ** rng.integers(-6, 3)
        dy = rng.standard_normal((n, *shape))
        tq = np.clip(rng.random(300) * 1.4 - 0.2, t[0], t[-1])
        pos, vel = CubicHermite(t, y, dy).evaluate(tq, derivative=True)
        ref_pos, ref_vel = _array_form(t, y, dy, tq, True)
        assert np.array_equal(pos, ref_pos, equal_nan=True) and np.array_equal(vel, ref_vel, equal_nan=True)
        assert pos.shape == (len(tq), *shape)


def _newton_array_form(spline: CubicHermite, target, start, iterations=3):
    """Newton's method with NumPy, as ``SimulationResult.time_at_travel`` did before the compiled loop."""
    t = np.asarray(start, dtype=float)
    for _ in range(iterations):
        pos, vel = spline.evaluate(t, derivative=True)
        t = np.clip(t - (pos - target) / np.maximum(vel, 1e-9), spline.t[0], spline.t[-1])
    return t


def test_the_compiled_inverse_is_the_array_form_newton_to_the_bit() -> None:
    rng = np.random.default_rng(11)
    for n in (1, 2, 5, 40):
        t = np.sort(rng.random(n))
        slopes = rng.random(n) + 0.01
        values = np.cumsum(slopes) * 0.01 + rng.normal(0, 1e-4, n)       # increasing, not exactly
        spline = CubicHermite(t, values, slopes)
        target = rng.uniform(values.min() - 0.01, values.max() + 0.01, 200)
        start = rng.uniform(t[0] - 0.1, t[-1] + 0.1, 200)                 # starts outside the span too
        got = spline.inverse(target, start)
        assert np.array_equal(got, _newton_array_form(spline, target, start), equal_nan=True), n
    assert np.isnan(spline.inverse(np.array([np.nan]), np.array([0.5]))[0])       # a NaN propagates as with NumPy
    grid = spline.inverse(target[:6].reshape(2, 3), start[:6].reshape(2, 3))          # any shape, kept
    assert grid.shape == (2, 3) and np.array_equal(grid.ravel(), got[:6])
