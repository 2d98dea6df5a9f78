"""The project's one cubic Hermite interpolator: values between recorded rows from values and slopes.

Every place that needs a trajectory between the integrator's accepted steps (``SimulationResult.sol``,
resampling by travel, the stand-in laboratory's samples, the workbench's travel at a time) uses
:class:`CubicHermite`, so they all agree to the last bit. Between two rows the curve is the cubic that
matches both rows' values and time derivatives: its error is O(h^4) for a smooth trajectory, the order of
the DOPRI5 steps that recorded the rows, which linear interpolation (O(h^2)) is not.

Rows may repeat a time (an event row): the interval search never picks a zero-length interval inside the
span, and :func:`distinct_times` drops all but the last of a repeated time where a caller wants that.
Queries outside the recorded span are clamped to its ends (no extrapolation).

:func:`linear` is the same module's piecewise-linear interpolation, for data that have values but no slopes
(measured samples, a controller's reference table, a resampling grid for a spectrum) or where only a first
guess is wanted (the start of a Newton refinement on the cubic).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def distinct_times(t: np.ndarray) -> np.ndarray:
    """Boolean mask keeping the last row of each run of equal times (``t`` non-decreasing)."""
    return np.append(np.diff(t) > 0, True)


def linear(x_query: float | np.ndarray, x: np.ndarray, y: np.ndarray,
           right: float | None = None) -> np.ndarray | float:
    """Piecewise-linear interpolation of ``y`` over increasing ``x`` at ``x_query`` (``numpy.interp``: queries
    outside ``x`` take the end values, or ``right`` beyond the last when given).

    Linear, not :class:`CubicHermite`, where the rows carry values only: a cubic Hermite needs each row's
    derivative, which a measured sample or a lookup table does not have (estimating it by differences would
    add overshoot between noisy samples without adding accuracy). Where a recorded trajectory has slopes,
    use :class:`CubicHermite`; this gives at most a starting guess there.
    """
    return np.interp(x_query, x, y, right=right)


class CubicHermite:
    """Cubic Hermite interpolant through ``values[k]`` with time derivatives ``slopes[k]`` at ``t[k]``.

    ``values`` and ``slopes`` have shape ``(n, ...)``; calling with times of shape ``(m,)`` returns
    ``(m, ...)``, with a scalar time ``(...)`` (like ``scipy``'s ``OdeSolution``, but rows first).
    """

    def __init__(self, t: np.ndarray, values: np.ndarray, slopes: np.ndarray):
        self.t = np.asarray(t, dtype=float)
        self.values = np.asarray(values, dtype=float)
        self.slopes = np.asarray(slopes, dtype=float)
        if self.t.ndim != 1 or not len(self.t):
            raise ValueError("t must be a non-empty 1-d array")
        if self.values.shape[0] != len(self.t) or self.slopes.shape != self.values.shape:
            raise ValueError(f"values {self.values.shape} and slopes {self.slopes.shape} must have "
                             f"{len(self.t)} rows each")
        if np.any(np.diff(self.t) < 0):
            raise ValueError("t must be non-decreasing")

    def __call__(self, t_query: float | np.ndarray) -> np.ndarray:
        return self.evaluate(t_query)[0]

    def evaluate(self, t_query: float | np.ndarray, derivative: bool = False
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        """``(values, d/dt values)`` at ``t_query`` (the derivative only when asked, else ``None``)."""
        scalar = np.ndim(t_query) == 0
        tq = np.clip(np.atleast_1d(np.asarray(t_query, dtype=float)), self.t[0], self.t[-1])
        pos, vel = self._evaluate(tq, derivative)
        if scalar:
            return pos[0], (vel[0] if vel is not None else None)
        return pos, vel

    def inverse(self, target: np.ndarray, start: np.ndarray, iterations: int = 3) -> np.ndarray:
        """Times at which a scalar interpolant (``values`` of shape ``(n,)``, increasing where it is inverted) takes
        the values ``target``: Newton's method on the cubic from ``start``, ``iterations`` steps, each clamped to
        the span (a slope below 1e-9 counts as 1e-9). One compiled loop: the same steps as evaluating the value and
        slope and updating ``t`` with NumPy, to the bit."""
        shape = np.shape(start)
        target = np.ascontiguousarray(np.broadcast_to(np.asarray(target, dtype=float), shape)).ravel()
        out = np.array(start, dtype=float).ravel()
        if len(self.t) == 1:          # a single row: every step lands on it
            for _ in range(iterations):
                pos, vel = self.evaluate(out, derivative=True)
                out = np.clip(out - (pos - target) / np.maximum(vel, 1e-9), self.t[0], self.t[-1])
            return out.reshape(shape)
        _hermite_inverse(self.t, np.ascontiguousarray(self.values.reshape(len(self.t), 1)),
                         np.ascontiguousarray(self.slopes.reshape(len(self.t), 1)), target, iterations, out)
        return out.reshape(shape)

    def _evaluate(self, tq: np.ndarray, derivative: bool) -> tuple[np.ndarray, np.ndarray | None]:
        t, y, dy = self.t, self.values, self.slopes
        if len(t) == 1:
            return np.repeat(y[:1], len(tq), axis=0), (np.zeros((len(tq),) + y.shape[1:]) if derivative else None)
        n, rest = len(t), y.shape[1:]
        pos = np.empty((len(tq), y[0].size))
        vel = np.empty_like(pos) if derivative else np.empty((0, 0))
        _hermite(t, np.ascontiguousarray(y.reshape(n, -1)), np.ascontiguousarray(dy.reshape(n, -1)),
                 np.ascontiguousarray(tq), derivative, pos, vel)
        return pos.reshape((len(tq),) + rest), (vel.reshape((len(tq),) + rest) if derivative else None)


@njit(cache=True, inline="always", error_model="numpy")
def _basis(t, tq, last):  # pragma: no cover (compiled)
    """The interval ``i`` holding ``tq`` (within the span), its length ``h`` and the cubic Hermite basis there, for
    the value ``(h00, h10, h01, h11)`` and for the slope ``(dh00, dh10, dh01, dh11)``."""
    i = min(max(np.searchsorted(t, tq, side="right") - 1, 0), last)
    h = t[i + 1] - t[i]
    u = (tq - t[i]) / h
    u2, u3 = u ** 2.0, u ** 3.0
    return (i, h, (2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2),
            (6 * u2 - 6 * u, 3 * u2 - 4 * u + 1, -6 * u2 + 6 * u, 3 * u2 - 2 * u))


@njit(cache=True, inline="always", error_model="numpy")
def _combine(w, y, dy, i, j, h):  # pragma: no cover (compiled)
    """Column ``j`` of rows ``i`` and ``i + 1`` weighed by the basis ``w`` (each term's products left to right)."""
    return w[0] * y[i, j] + w[1] * h * dy[i, j] + w[2] * y[i + 1, j] + w[3] * h * dy[i + 1, j]


@njit(cache=True, error_model="numpy")
def _hermite(t, y, dy, tq, derivative, pos, vel):  # pragma: no cover (compiled)
    """The cubic Hermite interpolant at each query, row by row (compiled: the workbench interpolates thousands of
    short runs, where NumPy's per-call overhead was most of the cost). The same operations in the same order as the
    array form it replaced (``u ** 2`` and ``u ** 3`` as powers, each term's products left to right), so the values
    are the same to the last bit (tests/triplanar/test_interpolate.py)."""
    last = t.shape[0] - 2
    for k in range(tq.shape[0]):
        i, h, w, dw = _basis(t, tq[k], last)
        for j in range(y.shape[1]):
            pos[k, j] = _combine(w, y, dy, i, j, h)
            if derivative:
                vel[k, j] = _combine(dw, y, dy, i, j, h) / h


@njit(cache=True, error_model="numpy")
def _hermite_inverse(t, y, dy, target, iterations, out):  # pragma: no cover (compiled)
    """Newton's method on a scalar cubic Hermite interpolant (``y``, ``dy``: one column), in place on ``out``
    (:meth:`CubicHermite.inverse`): the value and slope as :func:`_hermite` makes them, then ``t - (value - target) /
    max(slope, 1e-9)`` clamped to the span, with NumPy's ``maximum`` and ``clip`` semantics (a NaN propagates)."""
    last, lo, hi = t.shape[0] - 2, t[0], t[-1]
    for k in range(out.shape[0]):
        tk = out[k]
        for _ in range(iterations):
            tq = tk if tk != tk else min(max(tk, lo), hi)          # (evaluate's clamp; np.clip keeps a NaN)
            i, h, w, dw = _basis(t, tq, last)
            vel = _combine(dw, y, dy, i, 0, h) / h
            slope = vel if (vel != vel or vel >= 1e-9) else 1e-9      # np.maximum(vel, 1e-9)
            step = tk - (_combine(w, y, dy, i, 0, h) - target[k]) / slope
            tk = step if step != step else min(max(step, lo), hi)    # np.clip(..., lo, hi)
        out[k] = tk
