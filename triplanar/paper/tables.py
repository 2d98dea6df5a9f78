"""The numeric tables behind the paper's figures: one row per case and load.

* :class:`CaseRow` (cases A, B, C against the laboratory dataset, Figs. 11-13): distance between the
  model's paths and the measured ones at equal travel, the model's lateral dilation and rotation at the
  end of its travel (8 cm), its peak speed.
* :class:`DataRow` (the dataset itself, Fig. 6): lateral dilation and rotation at a travel every test
  reached, mean and spread over the repeats.
* :class:`ScaledRow` (cases D, E, F, Figs. 14-16): distance between the paths with and without end
  friction, and each one's dilation and rotation, in the reference size (positions divided by c).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measurement import MeasuredTest
from ..result import SimulationResult
from .cases import Run
from ..paths import lateral_dilation, rotation_deg
from .metrics import PathDistance, at_travel, data_vs_model, measured_peak_speed, measured_travel, model_vs_model, \
    peak_speed

#: Travel at which the dataset's repeats are compared with one another (every test reaches 5 cm).
DATA_COMPARE_TRAVEL_M = 0.05


@dataclass(frozen=True)
class CaseRow:
    case: str
    force_N: float
    distance: PathDistance          # model vs dataset
    dilation_m: np.ndarray          # (3,) model, end of travel
    rotation_deg: float             # model, end of travel
    dilation_at_compare_m: np.ndarray  # (3,) model at DATA_COMPARE_TRAVEL_M
    rotation_at_compare_deg: float
    peak_speed_m_s: float
    status: str
    travel_m: float


@dataclass(frozen=True)
class DataRow:
    force_N: float
    n_tests: int
    n_reached: int                   # tests that reached DATA_COMPARE_TRAVEL_M
    dilation_mean_m: np.ndarray      # (3,) at DATA_COMPARE_TRAVEL_M
    dilation_sd_m: np.ndarray
    rotation_mean_deg: float
    rotation_sd_deg: float
    end_travel_m: tuple[float, float]  # shortest and longest test
    peak_speed_m_s: float            # largest finite-difference CP1 speed over the repeats


@dataclass(frozen=True)
class ScaledRow:
    family: str
    factor: float
    force_N: float
    distance: PathDistance           # with vs without end friction, reference size
    dilation_A_m: np.ndarray         # (3,) reference size
    dilation_B_m: np.ndarray
    rotation_A_deg: float
    rotation_B_deg: float
    status: tuple[str, str]


def model_state_at(result: SimulationResult, travel_m: float) -> tuple[np.ndarray, float]:
    """(dilation (3,), rotation deg) of a simulated test at ``travel_m`` (or its end, if shorter)."""
    s = min(travel_m, float(result.travel[-1]))
    pos = result.resample_by_travel(np.array([s]))[-1]
    rest = result.contact_points[0]
    return lateral_dilation(pos, rest), float(rotation_deg(pos, rest))


def case_row(run: Run, result: SimulationResult, tests: list[MeasuredTest], rest: np.ndarray) -> CaseRow:
    """The model (from its first row) against the measured tests (from the specimen's ``rest``)."""
    dil_c, rot_c = model_state_at(result, DATA_COMPARE_TRAVEL_M)
    return CaseRow(run.case, run.force_N, data_vs_model(tests, result, rest),
                   lateral_dilation(result.contact_points[-1], result.contact_points[0]),
                   float(result.rotation_deg[-1]), dil_c, rot_c, peak_speed(result), result.status.label,
                   float(result.travel[-1]))


def data_row(force: float, tests: list[MeasuredTest], rest: np.ndarray) -> DataRow:
    states = [p for p in (at_travel(t, DATA_COMPARE_TRAVEL_M, rest) for t in tests) if p is not None]
    if states:
        arr = np.array(states)
        dil = lateral_dilation(arr, rest)
        rot = rotation_deg(arr, rest)
        dil_mean, dil_sd = dil.mean(axis=0), dil.std(axis=0, ddof=1) if len(arr) > 1 else np.zeros(3)
        rot_mean, rot_sd = float(rot.mean()), float(rot.std(ddof=1)) if len(arr) > 1 else 0.0
    else:
        dil_mean = dil_sd = np.full(3, np.nan)
        rot_mean = rot_sd = float("nan")
    ends = [float(measured_travel(t, rest)[-1]) for t in tests]
    return DataRow(force, len(tests), len(states), dil_mean, dil_sd, rot_mean, rot_sd, (min(ends), max(ends)),
                   max(measured_peak_speed(t) for t in tests))


def scaled_row(run_a: Run, result_a: SimulationResult, result_b: SimulationResult) -> ScaledRow:
    c = run_a.length_scale
    d = model_vs_model(result_a, result_b)
    dist = PathDistance(d.mean_m / c, d.max_m / c, d.n_samples)
    return ScaledRow(run_a.family, run_a.factor, run_a.force_N, dist,
                     lateral_dilation(result_a.contact_points[-1], result_a.contact_points[0]) / c,
                     lateral_dilation(result_b.contact_points[-1], result_b.contact_points[0]) / c,
                     float(result_a.rotation_deg[-1]), float(result_b.rotation_deg[-1]),
                     (result_a.status.label, result_b.status.label))


# -- markdown ------------------------------------------------------------------------------------

def _mm(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{x * 1e3:.1f}"


def _mm2(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{x * 1e3:.2f}"


def case_table_md(rows: list[CaseRow]) -> str:
    head = ("| load (N) | CP1 mean / max (mm) | CP2 mean / max (mm) | CP3 mean / max (mm) | model dilation "
            "CP1 / CP2 / CP3 at end (mm) | model rotation at end (deg) | model peak speed (m/s) | model end |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---|\n")
    lines = []
    for r in rows:
        dist = " | ".join(f"{_mm2(a)} / {_mm2(b)}" for a, b in zip(r.distance.mean_m, r.distance.max_m))
        dil = " / ".join(_mm(x) for x in r.dilation_m)
        lines.append(f"| {r.force_N:g} | {dist} | {dil} | {r.rotation_deg:+.2f} | {r.peak_speed_m_s:.3f} | "
                     f"{r.status}, {r.travel_m * 100:.1f} cm |")
    return head + "\n".join(lines) + "\n"


def data_table_md(rows: list[DataRow]) -> str:
    cm = DATA_COMPARE_TRAVEL_M * 100
    head = (f"| load (N) | tests | dilation CP1 / CP2 / CP3 at {cm:g} cm, mean (sd) (mm) | rotation at {cm:g} cm, "
            "mean (sd) (deg) | test lengths (cm) | peak CP1 speed (m/s) |\n|---:|---:|---:|---:|---:|---:|\n")
    lines = []
    for r in rows:
        dil = " / ".join(f"{_mm(m)} ({_mm(s)})" for m, s in zip(r.dilation_mean_m, r.dilation_sd_m))
        lines.append(f"| {r.force_N:g} | {r.n_tests} | {dil} | {r.rotation_mean_deg:+.2f} ({r.rotation_sd_deg:.2f}) | "
                     f"{r.end_travel_m[0] * 100:.1f}-{r.end_travel_m[1] * 100:.1f} | {r.peak_speed_m_s:.2f} |")
    return head + "\n".join(lines) + "\n"


def scaled_table_md(rows: list[ScaledRow]) -> str:
    head = ("| case | factor | load (N) | A vs B CP1 mean / max (mm) | CP2 mean / max (mm) | CP3 mean / max (mm) | "
            "dilation A: CP1 / CP2 / CP3 (mm) | dilation B (mm) | rotation A / B (deg) |\n"
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n")
    lines = []
    for r in rows:
        dist = " | ".join(f"{_mm2(a)} / {_mm2(b)}" for a, b in zip(r.distance.mean_m, r.distance.max_m))
        da = " / ".join(_mm(x) for x in r.dilation_A_m)
        db = " / ".join(_mm(x) for x in r.dilation_B_m)
        lines.append(f"| {r.family} | {r.factor:g} | {r.force_N:.4g} | {dist} | {da} | {db} | "
                     f"{r.rotation_A_deg:+.2f} / {r.rotation_B_deg:+.2f} |")
    return head + "\n".join(lines) + "\n"
