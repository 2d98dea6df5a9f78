"""Instrument or specimen? The rigid block's three contact points keep their mutual distances.

The specimen is one rigid block resting on the foundation at three contact points (Galic, Glaser & Goodman 2008,
section 3.1: the coordinates of P1, P2, P3 are the system's generalised coordinates; section 3.2, eq. 7: the rigid
body constraints ``|P2 - P1| = L12``, ``|P3 - P1| = L13``, ``|P3 - P2| = L23``, "the distance between contact points is
constant during sliding"; :mod:`triplanar.natural_coordinates` keeps the same three as constraints). Whatever force
acts on the block (friction, a tip, a tilted plane, a force outside the library) moves it as a rigid body, so the
three distances ``|CPi - CPj|`` along a measured path stay those of the block at rest, up to the rangefinders'
noise. A position channel that misreads breaks that: a gain or a drift on one channel makes a distance change that
grows with travel, an offset on one channel (or contact points that are not where the drawing puts them) a
constant difference from the drawing's distances. :func:`rigidity` tests both, for each pair of points, without
fitting any model.

The test. For each test and each pair, the distance ``D_k`` over the samples whose six coordinates are all measured
(x2 may be missing: docs/measurement-format.md; a sample without it is left out of that pair, a test with fewer than
:data:`MIN_SAMPLES` such samples is left out of it) is fitted by least squares as ``D = a + b s``, ``s`` the travel
(x1 from the test's first sample) of the third point, not of the pair: a point of the pair would carry the same noise
into ``s`` and ``D``, and that shared noise alone biases ``b`` (CP1-CP2 against CP1's travel: -sigma^2 / var(s),
-0.2 mm over 6 cm of travel at 1 mm noise, the same sign in every test). The noise of ``D`` is estimated from the
distances themselves: the residual of the lines, pooled over the tests of the pair (exact under rigidity; third
differences of ``D``, tried first, came out a few per cent low and doubled the false alarms at p < 0.01 on the
kernel's noise-free traces with Gaussian noise added, 200 draws x 48 tests); the mean lengthening it causes
(``sigma^2 / L``) is taken off ``a``; with independent noise each ``b / se(b)`` and each ``(a - L) / se(a)`` (``L`` the drawing's distance) is a standard normal
score under rigidity. Over the tests, Stouffer's sum (a change of one sign in every test) and the sum of squares
(chi-square with as many degrees of freedom as tests: a change that differs between tests) give a p-value, the
smaller of the two doubled; the statistic is the smallest p-value over the 3 pairs x 2 patterns, times 6
(Bonferroni), compared with :data:`ALPHA`. Under rigidity and independent Gaussian noise it falls below ``ALPHA`` in
about a fraction ``ALPHA`` of datasets or fewer, whatever the number of tests, samples or noise level: the threshold is
not tuned. Noise correlated in time (a real rangefinder's filter) would make it too eager; then the residual's
autocorrelation should be allowed for (not done: the project's generators draw independent noise).

What rigidity sees and what it cannot (each said in the result's sentence):

* a gain on one channel (one point's one axis), a drift or an offset of one channel: seen;
* a gain along one axis shared by the three points (the library's ``rangefinder_gain``): the triangle is
  stretched along that axis, which changes a distance only as the block turns (first order in the rotation for
  a pair not along an axis, CP1-CP3 of the reference): seen when the block turns enough;
* an offset or a drift shared by the three points (``rangefinder_offset``, ``rangefinder_drift``): a translation
  of the whole triangle, which keeps every distance: NOT seen;
* a load-cell gain, a time offset or a clock running fast or slow (``load_cell_gain``, ``time_offset``,
  ``time_base``): the positions are right: NOT seen. A time-base error would show in the relation of the forces to
  the accelerations (the equations of motion); that test is not built here.

A constant difference from the drawing alone (the distances do not change along the path) is
``instrument_or_drawing``: an offset on one channel and a contact point machined off the drawing are the same on
these data; measuring the block's contact points decides.

Constants: :data:`ALPHA` is a significance level (chosen, not fitted); :data:`DETECTABLE_LIMIT_MM` and
:data:`MIN_SAMPLES` were chosen before looking at data and checked on the calibration set's tuning seeds 1000-1033
(``benchmarks/workbench_calibration.py``; its independent natural-coordinates laboratory): none of them was changed
after that look. The regressor (the third point's travel) and the noise estimate (the lines' residual) were changed
after a check of the null on the kernel's rigid traces with Gaussian noise added (``benchmarks/rigidity_rates.py
--null``), not on the calibration set. The measured rates, on its seeds 1034-1099, are in docs/workbench.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from ..measurement import MeasuredTest
from .pooling import pooled_p

#: Family-wise significance level of the rigidity test (3 pairs x 2 patterns, Bonferroni).
ALPHA = 1e-3
#: Samples a test needs in a pair (a line and its residual: 8 leave 6 degrees of freedom for the noise).
MIN_SAMPLES = 8
#: ``undecided`` when the smallest change the data could show (at ALPHA, over the typical travel) exceeds this: the
#: library's instrument effects as the calibration set draws them (gain 10-25 %, offset 1-2.5 mm, drift 2-6 mm/s)
#: move a trace by a millimetre or more, so a test blind below a millimetre has nothing to say about them.
DETECTABLE_LIMIT_MM = 1.0
PAIRS = ((0, 1), (0, 2), (1, 2))
MM = 1e3


@dataclass(frozen=True)
class PairRigidity:
    """One pair of contact points over the tests: the change of its distance along the path (pooled slope times the
    median final travel, mm, and its standard error) and its start's difference from the drawing (mm), each with a
    p-value under rigidity; the noise of one distance sample (mm); tests and samples used."""

    pair: str
    rest_mm: float
    n_tests: int
    n_samples: int
    noise_mm: float
    change_mm: float
    change_se_mm: float
    p_travel: float
    offset_mm: float
    offset_se_mm: float
    p_offset: float

    def as_json(self) -> dict[str, Any]:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class RigidityResult:
    """The verdict of the rigidity test (module doc): ``kind`` one of ``instrument`` (distances change along the
    path beyond the noise), ``instrument_or_drawing`` (they differ from the drawing by a constant), ``specimen_or_load``
    (rigidity holds), ``undecided`` (too few samples, or noise too large); ``statistic`` the Bonferroni p-value,
    ``threshold`` :data:`ALPHA`; ``broken`` the pairs beyond the noise and ``pattern`` how; ``detectable_mm`` the
    smallest change the data could show; ``sentence`` what it means for the user."""

    kind: str
    statistic: float
    threshold: float
    pairs: tuple[PairRigidity, ...]
    broken: tuple[str, ...]
    pattern: str | None
    detectable_mm: float
    n_tests: int
    sentence: str

    def as_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "statistic": self.statistic, "threshold": self.threshold,
                "broken": list(self.broken), "pattern": self.pattern,
                "detectable_mm": self.detectable_mm if math.isfinite(self.detectable_mm) else None,
                "n_tests": self.n_tests, "pairs": [p.as_json() for p in self.pairs], "sentence": self.sentence}


def _residual_sd(runs: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Noise standard deviation of the distances: the residual of each test's line, pooled (N - 2 T degrees of
    freedom). Exact under rigidity; a change that is not a line in travel only inflates it (a weaker test)."""
    squares, dof = 0.0, 0
    for s, d in runs:
        fitted = np.polyval(np.polyfit(s, d, 1), s)
        squares += float(np.sum((d - fitted) ** 2))
        dof += len(s) - 2
    return math.sqrt(squares / dof) if dof > 0 else math.nan


def _pair(tests: Sequence[MeasuredTest], i: int, j: int, rest: np.ndarray) -> tuple[PairRigidity, float]:
    """The pair (i, j) over the tests, and its detectable change (mm) at ALPHA."""
    from scipy.stats import norm
    length = float(np.linalg.norm(rest[j] - rest[i]))
    runs = []
    for t in tests:
        x = np.asarray(t.positions, dtype=float)
        d = np.linalg.norm(x[:, j] - x[:, i], axis=1)
        k = 3 - i - j                   # the third point's travel: its noise is not in d (module doc)
        s = x[:, k, 0] - x[0, k, 0]
        ok = np.isfinite(d) & np.isfinite(s)
        if ok.sum() >= MIN_SAMPLES and np.ptp(s[ok]) > 0:
            runs.append((s[ok], d[ok]))
    name = f"CP{i + 1}-CP{j + 1}"
    sigma = _residual_sd(runs)
    if not runs or not sigma > 0:
        nan = math.nan
        return PairRigidity(name, length * MM, len(runs), 0, sigma * MM, nan, nan, 1.0, nan, nan, 1.0), math.inf
    slopes, slope_w, z_slope, offsets, offset_w, z_offset, travels = [], [], [], [], [], [], []
    for s, d in runs:
        sc = s - s.mean()
        sxx = float(sc @ sc)
        b = float(sc @ (d - d.mean())) / sxx
        a = float(d.mean()) - b * float(s.mean())
        se_b = sigma / math.sqrt(sxx)
        se_a = sigma * math.sqrt(1.0 / len(s) + float(s.mean()) ** 2 / sxx)
        slopes.append(b)
        slope_w.append(se_b ** -2)
        z_slope.append(b / se_b)
        # noise across the pair lengthens it on average by sigma^2 / L (two perpendicular directions, each sigma^2)
        offset = a - length - sigma ** 2 / length
        offsets.append(offset)
        offset_w.append(se_a ** -2)
        z_offset.append(offset / se_a)
        travels.append(float(np.max(s)))
    travel = float(np.median(travels))
    slope = float(np.average(slopes, weights=slope_w))
    slope_se = 1.0 / math.sqrt(float(np.sum(slope_w)))
    offset = float(np.average(offsets, weights=offset_w))
    offset_se = 1.0 / math.sqrt(float(np.sum(offset_w)))
    result = PairRigidity(name, length * MM, len(runs), sum(len(s) for s, _ in runs), sigma * MM,
                          slope * travel * MM, slope_se * travel * MM, pooled_p(np.array(z_slope)),
                          offset * MM, offset_se * MM, pooled_p(np.array(z_offset)))
    # the change a pooled test would just see: its z at ALPHA / 6, two-sided
    return result, float(norm.isf(ALPHA / 12)) * slope_se * travel * MM


BLIND = ("a load-cell gain, a time offset, a clock running fast or slow, or an offset or drift shared by the three points (a translation keeps "
         "every distance)")


def _sentence(kind: str, broken: Sequence[PairRigidity], detectable: float) -> str:
    if kind == "undecided":
        return (f"rigidity undecided: too few samples or too much noise (a change below {detectable:.2f} mm would "
                f"not show; a test needs {MIN_SAMPLES} samples with the coordinates of a pair)")
    if kind == "specimen_or_load":
        return (f"the block stays rigid within the noise (no distance between contact points changes by more than "
                f"{detectable:.2f} mm): what is missing is not a gain, offset or drift of one position channel; it is "
                f"in the specimen or the load, or an instrument error rigidity cannot see: {BLIND}")
    if kind == "instrument":
        sizes = ", ".join(f"{p.pair} {p.change_mm:+.2f} mm" for p in broken)
        return (f"the block is rigid, but its measured contact points are not: distances change along the path "
                f"({sizes} over the typical travel), growing with travel like a rangefinder gain or drift; no "
                f"specimen effect does this. Check the position channels first")
    sizes = ", ".join(f"{p.pair} {p.offset_mm:+.2f} mm" for p in broken)
    return (f"distances stay constant along the path but differ from the drawing ({sizes}): an offset on one "
            f"position channel, or contact points off the drawing; measuring the block's contact points decides")


def rigidity(tests: Sequence[MeasuredTest], rest: np.ndarray | None = None) -> RigidityResult:
    """Test the rigid-block relations on measured ``tests`` (module doc). ``rest``: (3, 3) contact points of the
    drawing (default: the reference specimen's), for the difference of the distances from the drawing."""
    if rest is None:
        from ..specimen import reference
        rest = reference()[0].contact_points_m
    rest = np.asarray(rest, dtype=float)
    if rest.shape != (3, 3) or not np.isfinite(rest).all():
        raise ValueError(f"rest: the drawing's contact points must be a finite (3, 3) array, got shape {rest.shape}")
    found = [_pair(tests, i, j, rest) for i, j in PAIRS]
    pairs = tuple(p for p, _ in found)
    usable = [(p, det) for p, det in found if p.n_tests > 0]
    detectable = min((det for _, det in usable), default=math.inf)
    statistic = min(1.0, 6 * min([p.p_travel for p in pairs] + [p.p_offset for p in pairs]))
    n_tests = max((p.n_tests for p in pairs), default=0)
    along = tuple(p for p in pairs if 6 * p.p_travel < ALPHA)
    offset = tuple(p for p in pairs if 6 * p.p_offset < ALPHA)
    if along:
        kind, broken, pattern = "instrument", along, "grows with travel"
    elif offset:
        kind, broken, pattern = "instrument_or_drawing", offset, "constant difference from the drawing"
    elif not usable or detectable > DETECTABLE_LIMIT_MM:
        kind, broken, pattern = "undecided", (), None
    else:
        kind, broken, pattern = "specimen_or_load", (), None
    return RigidityResult(kind, statistic, ALPHA, pairs, tuple(p.pair for p in broken), pattern, detectable, n_tests,
                          _sentence(kind, broken, detectable))
