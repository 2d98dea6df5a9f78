"""How far a model is from one measured test.

Paths are compared at equal CP1 travel, both measured from one rest position (:mod:`triplanar.paths`: the
block as seated on the model's foundation, the model run's first row): the model is
resampled at every measured travel (:meth:`SimulationResult.resample_by_travel`), and the horizontal
(x1, x3) distance between measured and modelled positions is taken for each contact point. Timing, when
the file has ``t_s``, is compared at equal time: CP1's modelled travel at each measured instant minus the
measured travel (the *travel lag*, in mm; it is the arrival-time error times the speed, and unlike a time
difference it stays well-conditioned at the start, where the block barely moves).

One number summarises a test, the **RMS discrepancy** (mm)::

    error_mm = sqrt( (sum over CP of mean_i |d_cp,i|^2  +  mean_i lag_i^2) / (3 + has_time) )

where ``d_cp,i`` is the position difference at equal travel: horizontal (x1, x3), plus vertical (x2) where
the file has it. The table reports the horizontal distance (what the paper's overhead plots show); the
vertical difference counts in the error because it is what tells a tilted foundation plane from changed
friction (a plane's dip sets how fast its contact point climbs; friction does not).

and :attr:`TestDiscrepancy.residuals` is a vector whose sum of squares is ``error_mm ** 2``: the quantity
the fits minimise (summed over tests, so every test weighs the same whatever its sample count).

A model run that ends before the measured travel (held, arrested, left a plane, lifted off) is compared
as far as it went: its last position stands in for the rest of the measured path, so the error is large
and finite, and the run's ``status`` is kept with the numbers.

The per-sample arithmetic of one test (differences, residuals, the sums) is compiled
(:mod:`triplanar.workbench.discrepancy_kernel`), bit for bit what numpy computes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..interpolate import linear
from ..measurement import MeasuredTest
from ..paths import lateral_dilation, model_at_travel, ran as _ran, rotation_deg, travel as path_travel
from ..result import SimulationResult
from ..outcome import Outcome
from .discrepancy_kernel import MM, per_test_terms

#: a test's ``status`` when no model run could be made (:class:`NoRun`); any other is an :class:`Outcome`'s label
NO_RUN = "invalid"

_NO_LAG = np.zeros(0)       # (the compiled terms take an array either way)
#: What a perfect model leaves on noise-free data: the integrator's tolerance seen through the comparison (mm). The
#: exact model of every library effect (tilted planes included) left at most 1.3e-5 mm on the stand-in laboratory's
#: noise-free traces (``tests/triplanar/workbench/test_travel_origin.py``); this is about 8 x that.
INTEGRATOR_FLOOR_MM = 1e-4


@dataclass(frozen=True, eq=False)
class TestDiscrepancy:
    """Discrepancy between one measured test and the model at its force (lengths in mm).

    Attributes:
        test_id, force_N: the measured test.
        status, message: how the model run ended (``travel`` when it covered the measured travel).
        mean_mm, max_mm: (3,) mean and max horizontal distance per contact point at equal travel.
        dilation_error_mm: (3,) measured minus modelled lateral (x3) dilation of each contact point at the
            end of the measured travel (both from the seated rest position).
        rotation_error_deg: measured minus modelled turn about the vertical at the end of the measured travel
            (angle of CP1->CP2 seen from above, positive counter-clockwise in the paper's overhead view).
        arrival_error_s: modelled minus measured time to reach the final measured travel (``nan`` without
            ``t_s`` or when the model never gets there).
        lag_rms_mm: RMS travel lag (``nan`` without ``t_s``).
        coverage: fraction of the measured travel the model reached.
        error_mm: the RMS discrepancy (module doc).
        travel_m: (n,) measured travel; lateral_mm: (n, 3) signed x3 error (measured minus model) per sample.
        residuals: the fit residual vector (sum of squares = error_mm ** 2).
        vertical_rms_mm: (3,) RMS vertical (x2) difference per contact point where the file has x2 (else nan).
        lag_mm, t_s: (n,) the travel lag at each measured instant and the instants (``None`` without ``t_s``):
            the evidence in time (:mod:`triplanar.workbench.evidence`).
    """

    __test__ = False  # not a pytest test class despite the name

    test_id: str
    force_N: float
    status: str
    message: str
    mean_mm: np.ndarray
    max_mm: np.ndarray
    dilation_error_mm: np.ndarray
    rotation_error_deg: float
    arrival_error_s: float
    lag_rms_mm: float
    coverage: float
    error_mm: float
    travel_m: np.ndarray
    lateral_mm: np.ndarray
    residuals: np.ndarray
    vertical_rms_mm: np.ndarray
    lag_mm: np.ndarray | None = None     # (n,) CP1's modelled minus measured travel at each instant (with t_s)
    t_s: np.ndarray | None = None        # (n,) the measured instants (with t_s)

    @property
    def has_time(self) -> bool:
        return math.isfinite(self.lag_rms_mm)

    @property
    def outcome(self) -> Outcome | None:
        """How the model run ended, as an :class:`~triplanar.outcome.Outcome` (``status`` is its label, what the
        reports write); ``None`` where no run could be made (``status`` :data:`NO_RUN`)."""
        return None if self.status == NO_RUN else Outcome.from_label(self.status)


def model_travel_at_time(result: SimulationResult, t: np.ndarray) -> np.ndarray:
    """CP1's modelled travel (m) at times ``t`` since sliding began (cubic Hermite between steps). After the
    run's end: extrapolated at the final speed when it ended at its travel target (the block still moves),
    otherwise held at the final travel."""
    t = np.asarray(t, dtype=float)
    if not _ran(result):
        return np.zeros_like(t)
    out = result.travel_at_time(t)
    t_end, s_end = float(result.t[-1]), float(result.travel[-1])
    beyond = t > t_end
    if beyond.any():
        speed = max(float(result.contact_velocities[-1, 0, 0]), 0.0) if result.status is Outcome.TRAVEL else 0.0
        out[beyond] = s_end + speed * (t[beyond] - t_end)
    return out


def seated_rest(result: SimulationResult | NoRun) -> np.ndarray:
    """(3, 3) the block at rest as seated on the model's foundation (the run's first row): the origin of both the
    measured and the modelled paths (:mod:`triplanar.paths`); the given rest positions where no run was made."""
    if isinstance(result, NoRun):
        return np.asarray(result.rest_positions, dtype=float)
    return result.contact_points[0]


def discrepancy(test: MeasuredTest, result: SimulationResult | NoRun) -> TestDiscrepancy:
    """Compare one measured test with a model run at its force."""
    return discrepancy_group([test], result)[0]


def discrepancy_group(tests: list[MeasuredTest] | tuple[MeasuredTest, ...],
                      result: SimulationResult | NoRun, arrival_time: bool = True) -> list[TestDiscrepancy]:
    """Compare several measured tests at one force with the model run at that force (one resampling of
    the run for all of them: the fits call this for every parameter vector). ``arrival_time`` False (the fits):
    no arrival times and no summary figures beyond ``error_mm``, ``residuals`` and the mean distance
    (:func:`_compare`)."""
    rest = seated_rest(result)
    travels = [np.maximum(path_travel(t.positions, rest), 0.0) for t in tests]
    ends = [int(np.argmax(s)) for s in travels]
    model_all = model_at_travel(result, np.concatenate(travels))
    reach = float(np.max(result.travel)) if _ran(result) else 0.0
    s_end = np.array([s[e] for s, e in zip(travels, ends)])
    timed = [t.t_s is not None for t in tests]
    arrival = np.full(len(tests), math.nan)
    ok = np.array(timed) & (s_end <= reach)
    if arrival_time and _ran(result) and ok.any():
        arrival[ok] = result.time_at_travel(s_end[ok]) - np.array([t.t_s[e] for t, e, k in zip(tests, ends, ok) if k])
    # CP1's modelled travel at every measured instant, for all timed tests at once (one interpolation)
    lag_all = model_travel_at_time(result, np.concatenate([t.t_s for t in tests if t.t_s is not None])) \
        if any(timed) else np.zeros(0)
    out, start, start_t = [], 0, 0
    for test, travel, end, arr in zip(tests, travels, ends, arrival):
        n = len(travel)
        model = model_all[start:start + n]
        start += n
        at_time = None
        if test.t_s is not None:
            at_time = lag_all[start_t:start_t + len(test.t_s)]
            start_t += len(test.t_s)
        out.append(_compare(test, result, travel, end, model, reach, float(arr), rest, at_time, arrival_time))
    return out


def _compare(test: MeasuredTest, result: SimulationResult | NoRun, travel: np.ndarray, end: int,
             model3: np.ndarray, reach: float, arrival: float, rest: np.ndarray,
             model_travel: np.ndarray | None = None, summary: bool = True) -> TestDiscrepancy:
    """One test's discrepancy. ``summary`` False (a fit's evaluations, which need only ``error_mm`` and
    ``residuals``): the end-of-travel dilation and rotation errors, the max and vertical figures are NaN."""
    s_end = float(travel[end])
    if summary:      # (one rest for both: the differences of dilation and turn are those of positions)
        dilation = lateral_dilation(test.positions[end], rest) - lateral_dilation(model3[end], rest)
        rotation = rotation_deg(test.positions[end], rest) - rotation_deg(model3[end], rest)
    else:
        dilation, rotation = np.full(3, math.nan), math.nan
    coverage = 1.0 if s_end <= 0 else min(1.0, reach / s_end)
    lag = None
    if test.t_s is not None:
        if model_travel is None:
            model_travel = model_travel_at_time(result, test.t_s)
        lag = (model_travel - travel) * MM
    d, dist, dv, residuals, error, mean, lag_rms = per_test_terms(
        np.ascontiguousarray(test.positions, dtype=float), np.ascontiguousarray(model3, dtype=float),
        _NO_LAG if lag is None else lag, lag is not None)
    if summary:
        counts = np.isfinite((test.positions[:, :, 1] - model3[:, :, 1]) * MM).sum(axis=0)
        vertical = np.where(counts > 0, np.sqrt(np.sum(dv**2, axis=0) / np.maximum(counts, 1)), math.nan)
        largest = dist.max(axis=0)
    else:
        vertical = largest = np.full(3, math.nan)
    return TestDiscrepancy(
        test_id=test.test_id, force_N=float(test.shear_force_N), status=str(result.status), message=result.message,
        mean_mm=mean, max_mm=largest, dilation_error_mm=dilation * MM,
        rotation_error_deg=float(rotation), arrival_error_s=arrival, lag_rms_mm=lag_rms,
        coverage=coverage, error_mm=error, travel_m=travel, lateral_mm=d[..., 1], residuals=residuals,
        vertical_rms_mm=vertical, lag_mm=lag, t_s=test.t_s)


@dataclass(frozen=True)
class NoRun:
    """Stands in for a model run that could not be made (e.g. parameters the specimen check refuses): the
    block stays at its rest positions, so the discrepancy is the whole measured motion."""

    rest_positions: np.ndarray
    message: str
    status: str = NO_RUN

    @property
    def contact_points(self) -> np.ndarray:
        return np.asarray(self.rest_positions, dtype=float)[None]

    @property
    def t(self) -> np.ndarray:
        return np.zeros(1)

    @property
    def travel(self) -> np.ndarray:
        return np.zeros(1)


def rms(values: np.ndarray | list[float]) -> float:
    """Root mean square (``nan`` for no values)."""
    values = np.asarray(values, dtype=float)
    return float(np.sqrt(np.mean(values**2))) if values.size else math.nan


def _interp_or_nan(grid: np.ndarray, s: np.ndarray, values: np.ndarray) -> np.ndarray:
    ok = np.isfinite(values)
    if ok.sum() < 2:
        return np.full_like(grid, math.nan)
    return linear(grid, s[ok], values[ok])


def group_by_force(tests: Sequence[MeasuredTest]) -> dict[float, tuple[MeasuredTest, ...]]:
    """Tests grouped by commanded force (in order of the forces)."""
    groups: dict[float, list[MeasuredTest]] = {}
    for test in tests:
        groups.setdefault(float(test.shear_force_N), []).append(test)
    return {f: tuple(groups[f]) for f in sorted(groups)}


def repeat_scatter_mm(tests: list[MeasuredTest], rest_positions: np.ndarray, grid_points: int = 40) -> float:
    """The RMS discrepancy a perfect model would still show: how far repeats at one force stray from their
    common mean path, in the units of ``error_mm`` (``nan`` when no force has two repeats).

    Each repeat is resampled at common travels from the specimen's ``rest_positions`` (and, with time, its
    travel at common times); the deviation from the repeats' mean is scaled by sqrt(k / (k - 1)) to
    estimate the deviation from the true path. Never below the integrator's tolerance
    (:data:`INTEGRATOR_FLOOR_MM`): a perfect simulated model shows at least that,
    however alike noise-free repeats are.
    """
    squares: list[float] = []
    for group in group_by_force(tests).values():
        k = len(group)
        if k < 2:
            continue
        travels = [path_travel(t.positions, rest_positions) for t in group]
        reach = min(float(np.max(s)) for s in travels)
        grid = np.linspace(0.0, reach, grid_points)
        paths = []
        for t, s in zip(group, travels):
            s = np.maximum.accumulate(np.maximum(s, 0.0))
            s = s + np.arange(len(s)) * 1e-12                   # strictly increasing for interpolation
            paths.append(np.stack([[_interp_or_nan(grid, s, t.positions[:, c, a]) for a in (0, 1, 2)]
                                   for c in range(3)]))
        paths = np.array(paths) * MM                          # (k, 3, 3, m)
        dev = paths - paths.mean(axis=0)
        dev = np.where(np.isfinite(dev), dev, 0.0)            # x2 not measured: it does not count
        per_cp = np.sum(dev**2, axis=2).mean(axis=2) * k / (k - 1)  # (k, 3)
        groups = 3
        total = per_cp.sum(axis=1)
        if all(t.t_s is not None for t in group):
            groups = 4
            t_end = min(float(t.t_s[-1]) for t in group)
            tg = np.linspace(0.0, t_end, grid_points)
            s_t = np.array([linear(tg, t.t_s, s) for t, s in zip(group, travels)]) * MM
            lag = np.mean((s_t - s_t.mean(axis=0)) ** 2, axis=1) * k / (k - 1)
            total = total + lag
        squares.extend((total / groups).tolist())
    return max(float(np.sqrt(np.mean(squares))), INTEGRATOR_FLOOR_MM) if squares else math.nan
