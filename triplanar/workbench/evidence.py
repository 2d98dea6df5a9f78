"""What the residuals say beyond their size: instrument noise, expected repeat scatter, evidence in time.

* :func:`instrument_noise_mm`: the rangefinder's noise estimated from the data alone, from third differences
  of every coordinate along its samples (``var(x[i+2] - 3 x[i+1] + 3 x[i] - x[i-1]) = 20 sigma^2`` for white
  noise; median absolute deviation, so that a few glitches do not count). Third, not second: smooth motion at
  200 Hz leaves 0.003-0.005 mm in the second-difference estimate of noise-free traces and 1e-5-1e-4 mm in the
  third's (the stand-in laboratory's end friction, rate friction and actuator rise; with 0.2 mm noise the two
  agree within 1 %).
* :func:`noise_floor_mm`: the RMS discrepancy (units of ``error_mm``) that this noise alone gives a perfect model;
  :func:`pattern_floor_mm` the same, never below the integrator's tolerance: below :data:`WITHIN_NOISE_FACTOR` x it
  a residual is reported as noise, with no location, trend or frequency (:func:`triplanar.workbench.compare`).
* :func:`expected_scatter_mm`: the repeat scatter the noise and the specimen's own variability explain. The
  variability is the friction angles' repeat-to-repeat scatter (``sigma_deg``, an assumption the user sets;
  the shipped data's laboratory has 0.2 deg), propagated through the model linearly: one extra evaluation
  per contact angle, shifted by ``STEP_DEG``.
* :func:`time_domain`: arrival-time error, travel lag, and the residual spectrum of every test (lateral error
  of each contact point and the travel lag against time, detrended by a cubic, Hann window): a test has a
  *periodic* residual when its spectrum's highest bin above ``F_MIN_HZ`` is a peak (above both neighbouring bins:
  a smooth residual's leakage falls with frequency from below the band) and exceeds ``PEAK_FACTOR`` x its median
  power;
  the data show a dominant frequency when at least half the tests long enough to look are periodic.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Callable, Sequence

import numpy as np

from ..interpolate import linear
from ..measurement import MeasuredTest
from ..outcome import Outcome
from .discrepancy import INTEGRATOR_FLOOR_MM, MM, TestDiscrepancy, rms
from .pooling import pooled_p
# the detectors' thresholds are constants of the verdict's rules, kept together with them
from .rules import HINT_ALPHA, MOSTLY_IN_TIME, PEAK_FACTOR, SYSTEMATIC_ALPHA

#: Frequencies below this are trends, not oscillations (a test lasts 0.3-1 s).
F_MIN_HZ = 2.0
#: Step of the friction angles for the linear propagation of the specimen's variability.
STEP_DEG = 1.0


def instrument_noise_mm(tests: Sequence[MeasuredTest]) -> float:
    """Standard deviation of the position noise (mm), robustly from third differences (module doc)."""
    parts = []
    for t in tests:
        x = np.asarray(t.positions, dtype=float)
        if len(x) < 4:
            continue
        d3 = np.diff(x, n=3, axis=0).ravel()
        parts.append(d3[np.isfinite(d3)])
    if not parts:
        return math.nan
    d3 = np.concatenate(parts)
    mad = float(np.median(np.abs(d3 - np.median(d3))))
    return 1.4826 * mad / math.sqrt(20.0) * MM


def noise_floor_mm(tests: Sequence[MeasuredTest], noise_mm: float) -> float:
    """RMS discrepancy a perfect model shows from instrument noise alone (the ``error_mm`` formula with every
    measured coordinate, and CP1's travel for the lag, off by ``noise_mm``)."""
    squares = []
    for t in tests:
        coords = sum(2 + int(np.isfinite(t.positions[:, c, 1]).any()) for c in range(3))
        timed = int(t.t_s is not None)
        squares.append(noise_mm ** 2 * (coords + timed) / (3 + timed))
    return math.sqrt(float(np.mean(squares))) if squares else math.nan


#: An RMS discrepancy up to this many times :func:`pattern_floor_mm` is what noise alone leaves a perfect model.
#: Expected ratio about 1.05 (a perfect model evaluated at the noisy travel: CP1's x1 noise cancels, the lag and
#: CP2/CP3's x1 carry it twice); measured 1.04-1.09 for the exact model of each library effect with 0.2 mm noise
#: (2 loads x 2 repeats, seed 11); a test's hundreds of residuals make the RMS scatter by a few percent.
WITHIN_NOISE_FACTOR = 1.25


def pattern_floor_mm(tests: Sequence[MeasuredTest]) -> float:
    """The RMS discrepancy (mm) below which a residual is noise, not a pattern: :func:`noise_floor_mm` of the
    noise estimated from the traces, and never below :data:`INTEGRATOR_FLOOR_MM` (noise-free data)."""
    floor = noise_floor_mm(tests, instrument_noise_mm(tests))
    return max(floor, INTEGRATOR_FLOOR_MM) if math.isfinite(floor) else INTEGRATOR_FLOOR_MM


def expected_scatter_mm(spec: Any, tests: Sequence[MeasuredTest], noise_mm: float, sigma_deg: float,
                        evaluate: Callable[[Any, Sequence[MeasuredTest]], list[TestDiscrepancy]]) -> float:
    """Repeat scatter that instrument noise and the specimen's friction scatter ``sigma_deg`` explain (mm,
    units of ``error_mm``): ``sqrt(floor^2 + sigma^2 sum_i |dr/dphi_i|^2)``, RMS over tests; the noise floor never
    below the integrator's tolerance (:data:`INTEGRATOR_FLOOR_MM`)."""
    from ..specimen import reference
    floor = max(noise_floor_mm(tests, noise_mm), INTEGRATOR_FLOOR_MM)
    if sigma_deg <= 0:
        return floor
    specimen = spec.specimen or reference()[0]
    base = {d.test_id: d.residuals for d in evaluate(spec, tests)}
    sens = {k: 0.0 for k in base}
    # the angles the model uses: an effect of the model may set them (contact_friction), and then shifting the
    # specimen's would change nothing (the scatter would seem unexplained); such a model is shifted by one more
    # contact_friction effect on top, which replaces the angles it set
    names = [name for name, _ in getattr(spec, "effects", ())]
    in_use = None
    if "contact_friction" in names and tests:
        in_use = tuple(float(a) for a in spec.build(float(tests[0].shear_force_N)).specimen.friction_deg)
    for i in range(3):
        if in_use is not None:
            angles = list(in_use)
            angles[i] += STEP_DEG
            shifted = spec.with_effects([("contact_friction", tuple((f"phi{j + 1}_deg", a)
                                                                    for j, a in enumerate(angles)))])
        else:
            angles = list(specimen.friction_deg)
            angles[i] += STEP_DEG
            shifted = replace(spec, specimen=replace(specimen, friction_deg=tuple(angles)),
                              foundation=spec.foundation or reference()[1])
        for d in evaluate(shifted, tests):
            r0 = base[d.test_id]
            if len(r0) == len(d.residuals):
                sens[d.test_id] += float(np.sum((d.residuals - r0) ** 2)) / STEP_DEG ** 2
    variability = float(np.mean(list(sens.values()))) * sigma_deg ** 2 if sens else 0.0
    return math.sqrt(floor ** 2 + variability)


def _series(d: TestDiscrepancy) -> list[np.ndarray]:
    out = [d.lateral_mm[:, c] for c in range(d.lateral_mm.shape[1])]
    if d.lag_mm is not None:
        out.append(d.lag_mm)
    return out


def residual_spectrum(d: TestDiscrepancy) -> tuple[np.ndarray, np.ndarray] | None:
    """(frequencies Hz, power summed over the test's residual series) on a uniform time grid; ``None``
    without time or with fewer than 24 samples."""
    if d.t_s is None or len(d.t_s) < 24:
        return None
    t = np.asarray(d.t_s, dtype=float)
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return None
    grid = np.arange(t[0], t[-1], dt)
    if len(grid) < 24:
        return None
    window = np.hanning(len(grid))
    tau = (grid - grid.mean()) / max(float(np.ptp(grid)), dt)
    basis = np.vander(tau, 4)
    power = np.zeros(len(grid) // 2 + 1)
    for series in _series(d):
        ok = np.isfinite(series)
        if ok.sum() < 24:
            continue
        y = linear(grid, t[ok], series[ok])
        y = y - basis @ np.linalg.lstsq(basis, y, rcond=None)[0]
        power += np.abs(np.fft.rfft(y * window)) ** 2
    return np.fft.rfftfreq(len(grid), dt), power


def dominant_frequency(d: TestDiscrepancy) -> tuple[float, bool]:
    """(peak frequency above F_MIN_HZ, whether it stands out: periodic) of one test's residual (nan, False
    without a spectrum)."""
    spec = residual_spectrum(d)
    if spec is None:
        return math.nan, False
    f, p = spec
    band = f >= F_MIN_HZ
    if band.sum() < 4 or not np.any(p[band] > 0):
        return math.nan, False
    k = int(np.argmax(np.where(band, p, -1.0)))
    # a periodic residual makes a peak: higher than the bins on both sides. A smooth residual that the cubic does
    # not take out (a lag growing in some other way) leaks into the lowest bins with power falling with frequency,
    # so the band's highest bin is its first, below which the power is higher still: that is not a peak.
    peak = 0 < k < len(p) - 1 and p[k] > p[k - 1] and p[k] > p[k + 1]
    return float(f[k]), bool(peak and p[k] > PEAK_FACTOR * float(np.median(p[band])))


def within_integrator_tolerance(found: Sequence[TestDiscrepancy]) -> bool:
    """Whether the model matches every test to the integrator's tolerance (noise-free data, the exact model): then
    no residual has a shape worth naming (no frequency, growth or shared bias: :func:`time_domain`,
    :func:`growth_along_travel`, :func:`systematic_bias`): the detectors, made for noisy data, would otherwise read
    shapes into the integrator's sub-micrometre error (FP1 tilted 0.4 deg sideways, exact model, noise-free:
    "periodic at 48.1 Hz", "systematic" at 1e-6 mm)."""
    errors = [d.error_mm for d in found]
    return bool(errors) and all(d.outcome is Outcome.TRAVEL for d in found) \
        and rms(errors) <= WITHIN_NOISE_FACTOR * INTEGRATOR_FLOOR_MM


def time_domain(found: Sequence[TestDiscrepancy]) -> dict[str, Any]:
    """Evidence in time for one model against the tests (``docs/workbench.md``, ``time_domain``)."""
    timed = [d for d in found if d.lag_mm is not None]
    arrival = [d.arrival_error_s for d in timed if math.isfinite(d.arrival_error_s)]
    peaks = [] if within_integrator_tolerance(found) else [dominant_frequency(d) for d in timed]
    looked = [(f, yes) for f, yes in peaks if math.isfinite(f)]
    periodic = [f for f, yes in looked if yes]
    fraction = len(periodic) / len(looked) if looked else 0.0
    lag = rms([d.lag_rms_mm for d in timed]) if timed else math.nan
    distance = float(np.mean([d.mean_mm.mean() for d in found])) if found else math.nan
    return {
        "has_time": bool(timed),
        "arrival_error_s": float(np.mean(arrival)) if arrival else None,
        "arrival_error_rms_s": rms(arrival) if arrival else None,
        "lag_rms_mm": lag if timed else None,
        "mean_distance_mm": distance,
        "mostly_in_time": bool(timed) and math.isfinite(lag) and lag > MOSTLY_IN_TIME * distance,
        "dominant_frequency_hz": float(np.median(periodic)) if fraction >= 0.5 else None,
        "periodic_fraction": fraction,
    }


def growth_along_travel(found: Sequence[TestDiscrepancy]) -> float:
    """RMS lateral error over the last third of the travel divided by that over the first third (mean over
    tests; > 2: the error grows with travel; ``nan`` within the integrator's tolerance)."""
    if within_integrator_tolerance(found):
        return math.nan
    ratios = []
    for d in found:
        n = len(d.travel_m)
        if n < 9:
            continue
        first, last = d.lateral_mm[: n // 3], d.lateral_mm[-(n // 3):]
        a, b = rms(first.ravel()), rms(last.ravel())
        if a > 0 and math.isfinite(b):
            ratios.append(b / a)
    return float(np.median(ratios)) if ratios else math.nan




def _features(d: TestDiscrepancy) -> dict[str, float]:
    """Signed residuals of one test that a bias shared by every test moves the same way: the mean lateral (x3)
    error of each contact point over the travel, the rotation error at its end, the mean travel lag (with time)."""
    out = {f"mean x3 error CP{k + 1} (mm)": float(np.nanmean(d.lateral_mm[:, k])) for k in range(3)}
    out["rotation error (deg)"] = float(d.rotation_error_deg)
    if d.lag_mm is not None and len(d.lag_mm):
        out["mean travel lag (mm)"] = float(np.nanmean(d.lag_mm))
    return out


def _level_scores(found: Sequence[TestDiscrepancy]) -> dict[str, tuple[list[float], list[float], list[float]]]:
    """Per feature: each load level's signed normal score z of its repeats' mean (Student's t, n - 1 degrees of
    freedom, turned into a normal score), the means and their standard errors (levels with 2 repeats or more)."""
    from scipy.stats import norm
    from scipy.stats import t as student_t
    groups: dict[float, list[dict[str, float]]] = {}
    for d in found:
        if d.outcome is Outcome.TRAVEL:
            groups.setdefault(d.force_N, []).append(_features(d))
    names = sorted({k for rows in groups.values() for row in rows for k in row})
    out = {}
    for name in names:
        zs, means, ses = [], [], []
        for rows in groups.values():
            x = np.array([r[name] for r in rows if name in r and math.isfinite(r[name])])
            if len(x) < 2:
                continue
            se = float(np.std(x, ddof=1) / math.sqrt(len(x)))
            if not se > 1e-12:
                continue
            p_lower = float(student_t.cdf(float(x.mean()) / se, len(x) - 1))
            zs.append(float(norm.ppf(min(max(p_lower, 1e-300), 1 - 1e-16))))
            means.append(float(x.mean()))
            ses.append(se)
        out[name] = (zs, means, ses)
    return out


def bias_ratio(found: Sequence[TestDiscrepancy]) -> float:
    """How far the per-load means of the residuals stand from zero, in their own standard errors: the largest over
    the features of ``sqrt(mean z^2)`` over the load levels (about 1 when the model is right; at least 1). A Birge
    ratio at the level of the means, which a bias below the scatter of one test still moves: the intervals'
    allowance for model-form error (:func:`triplanar.workbench.intervals.interval95`)."""
    ratios = [math.sqrt(float(np.mean(np.square(zs)))) for zs, _, _ in _level_scores(found).values() if len(zs) >= 2]
    return max([1.0, *ratios])


def model_form_allowance(found: Sequence[TestDiscrepancy]) -> float:
    """The factor the intervals' standard errors get for a bias below the scatter: :func:`bias_ratio` where the
    residual means hint at a shared bias (:func:`systematic_bias` p < ``HINT_ALPHA``), else 1. Without that evidence
    the ratio, a maximum over features of a few levels each, is itself noise (1.0-1.7 on clean data) and would only
    widen right intervals."""
    if systematic_bias(found)["p_value_all"] >= HINT_ALPHA:
        return 1.0
    return bias_ratio(found)


def systematic_bias(found: Sequence[TestDiscrepancy], alpha: float = SYSTEMATIC_ALPHA) -> dict[str, Any]:
    """Is there an error shared by the tests that their scatter hides? Per load level and signed feature
    (:func:`_features`), the mean over the repeats is tested against its own standard error (Student's t with
    n - 1 degrees of freedom; a level needs 2 repeats); each level's two-sided p-value becomes a signed normal
    score z. Over the levels, Stouffer's sum (a bias of one sign at every load) and the sum of z^2 (a bias that
    changes with load) give a feature's p-value (the smaller, doubled); the data show a systematic error when the
    smallest feature p-value, times the number of features, is below ``alpha``. With n tests per level a shared
    bias is seen at about ``scatter / sqrt(n_tests)``, not at the scatter of one test."""
    scores = {} if within_integrator_tolerance(found) else _level_scores(found)
    names = sorted(scores)
    best: dict[str, Any] = {"systematic": False, "p_value": 1.0, "feature": None, "z": 0.0, "mean": None,
                            "standard_error": None, "levels": 0}
    for name in names:
        zs, means, ses = scores[name]
        if len(zs) < 2:
            continue
        z = float(np.sum(zs) / math.sqrt(len(zs)))
        p = pooled_p(np.asarray(zs, dtype=float))
        if p < best["p_value"] or best["feature"] is None:
            best = {"systematic": False, "p_value": p, "feature": name, "z": z,
                    "mean": float(np.mean(means)), "standard_error": float(math.sqrt(np.sum(np.square(ses)))
                                                                           / len(ses)),
                    "levels": len(zs)}
    best["n_features"] = len(names)
    best["p_value_all"] = min(1.0, best["p_value"] * max(1, len(names)))
    best["systematic"] = bool(best["feature"] is not None and best["p_value_all"] < alpha)
    return best
