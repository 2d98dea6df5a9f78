"""Compare a model with measured tests: the discrepancy table and a plain-language account of the pattern.

>>> from triplanar.workbench import compare, ModelSpec, load_tests          # doctest: +SKIP
>>> tests = load_tests("data/lab_traces.csv")
>>> cmp = compare(tests, ModelSpec())            # case B, reference specimen
>>> print(cmp.summary()); cmp.write_csv("out/compare.csv")
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..atomic import write_atomic
from ..measurement import MeasuredTest, read_measurements
from ..outcome import Outcome
from ..specimen import Specimen
from .discrepancy import TestDiscrepancy, rms
from .executor import ExecutorLike, run_tasks
from .fit import errors_by_load, overall_error, safe_evaluate
from .spec import EvalResult, ModelSpec, tasks_for

TABLE_COLUMNS = ("test_id", "shear_force_N", "cp", "model_status", "mean_distance_mm", "max_distance_mm",
                 "vertical_rms_mm", "lateral_dilation_error_mm", "rotation_error_deg", "arrival_time_error_s",
                 "travel_lag_rms_mm",
                 "coverage", "test_error_mm", "note")


def load_tests(path: str | os.PathLike[str], specimen: Specimen | None = None) -> list[MeasuredTest]:
    """Read a measured-trace CSV, checking each test's first sample against the specimen's rest positions
    (default: the reference specimen). Raises :class:`triplanar.MeasurementError` naming row and column."""
    from ..specimen import reference
    rest = (specimen or reference()[0]).contact_points_m
    return read_measurements(path, rest_positions=rest)


@dataclass
class Comparison:
    """A model against a set of tests (:func:`compare` makes one).

    Attributes: ``spec``; ``discrepancies`` (per test, in file order); ``runs`` (per force, the model run,
    kept for plotting); ``error_mm`` (RMS discrepancy over tests); ``error_by_load``.
    """

    spec: ModelSpec
    tests: list[MeasuredTest]
    discrepancies: list[TestDiscrepancy]
    runs: dict[float, EvalResult]

    @property
    def error_mm(self) -> float:
        return overall_error(self.discrepancies)

    @property
    def error_by_load(self) -> dict[float, float]:
        return errors_by_load(self.discrepancies)

    def note(self, d: TestDiscrepancy) -> str:
        run = self.runs[d.force_N]
        if d.outcome is Outcome.TRAVEL:
            return ""
        if d.outcome is Outcome.HELD:
            thr = f" (the model's sliding threshold is {run.threshold_N:.2f} N)" if run.threshold_N else ""
            return (f"the model never slides at {d.force_N:g} N{thr}, but the test did: compared against the "
                    "rest position")
        return f"model run ended early ({d.status}): {d.message}; compared as far as it went"

    def rows(self) -> list[dict[str, object]]:
        """The table: one row per test and contact point."""
        out = []
        for d in self.discrepancies:
            note = self.note(d)
            for cp in range(3):
                out.append({"test_id": d.test_id, "shear_force_N": d.force_N, "cp": cp + 1, "model_status": d.status,
                            "mean_distance_mm": d.mean_mm[cp], "max_distance_mm": d.max_mm[cp],
                            "vertical_rms_mm": d.vertical_rms_mm[cp],
                            "lateral_dilation_error_mm": d.dilation_error_mm[cp],
                            "rotation_error_deg": d.rotation_error_deg, "arrival_time_error_s": d.arrival_error_s,
                            "travel_lag_rms_mm": d.lag_rms_mm, "coverage": d.coverage, "test_error_mm": d.error_mm,
                            "note": note})
        return out

    def write_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write the table (atomically); numbers with 6 significant digits, NaN as empty."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        rows = self.rows()

        def write(tmp: Path) -> None:
            with open(tmp, "w", newline="", encoding="utf-8") as fh:
                writer = csv.DictWriter(fh, fieldnames=TABLE_COLUMNS, lineterminator="\n")
                writer.writeheader()
                for row in rows:
                    writer.writerow({k: _fmt(v) for k, v in row.items()})
        write_atomic(path, write)
        return path

    def cp_by_load(self) -> tuple[list[float], np.ndarray]:
        """(loads, (n_loads, 3) mean horizontal distance per load level and contact point, mm)."""
        loads = sorted({d.force_N for d in self.discrepancies})
        grid = np.array([[np.mean([d.mean_mm[cp] for d in self.discrepancies if d.force_N == f]) for cp in range(3)]
                         for f in loads])
        return loads, grid

    def summary(self) -> str:
        """A readable summary for the terminal: per load level, then the pattern in plain language."""
        lines = [f"model: {self.spec.describe()}",
                 f"{len(self.discrepancies)} tests at {len(self.runs)} load levels; "
                 f"RMS discrepancy {self.error_mm:.2f} mm", "",
                 "  load N  tests  mean distance CP1/CP2/CP3 mm   max mm   dilation err CP1 mm  rotation err deg"
                 "  arrival err s  status"]
        for f in sorted(self.runs):
            group = [d for d in self.discrepancies if d.force_N == f]
            mean = np.mean([d.mean_mm for d in group], axis=0)
            mx = max(float(d.max_mm.max()) for d in group)
            dil = np.mean([d.dilation_error_mm[0] for d in group])
            rot = np.mean([d.rotation_error_deg for d in group])
            arr = [d.arrival_error_s for d in group if math.isfinite(d.arrival_error_s)]
            arr_txt = f"{np.mean(arr):+.3f}" if arr else "-"
            lines.append(f"  {f:6.1f}  {len(group):5d}   {mean[0]:6.2f} {mean[1]:6.2f} {mean[2]:6.2f}"
                         f"              {mx:6.2f}   {dil:+8.2f}             {rot:+7.2f}         {arr_txt:>7s}"
                         f"   {self.runs[f].status}")
        lines += ["", "pattern: " + self.pattern()]
        return "\n".join(lines)

    def pattern(self) -> str:
        """Where the model fails, in plain language (which contact point, which loads, which direction); an error
        within the traces' own noise (or, noise-free, the integrator's tolerance) is said to be so, and no more."""
        from .evidence import pattern_floor_mm
        return describe_pattern(self.discrepancies, {f: r.status for f, r in self.runs.items()},
                                {f: r.threshold_N for f, r in self.runs.items()}, pattern_floor_mm(self.tests))


def _fmt(value: object) -> object:
    if isinstance(value, (float, np.floating)):
        return "" if not math.isfinite(float(value)) else f"{float(value):.6g}"
    return value


def describe_pattern(found: Sequence[TestDiscrepancy], status: dict[float, str] | None = None,
                     thresholds: dict[float, float | None] | None = None, floor_mm: float | None = None) -> str:
    """Plain-language summary of a discrepancy pattern (the "see where it fails" sentence). ``floor_mm``: what
    noise leaves a perfect model (:func:`~triplanar.workbench.evidence.pattern_floor_mm`); an error within
    ``WITHIN_NOISE_FACTOR`` x it is reported as noise, without location, trend or frequency (those would describe
    the noise)."""
    if not found:
        return "no tests"
    sentences = []
    loads = sorted({d.force_N for d in found})
    per_cp = np.mean([d.mean_mm for d in found], axis=0)
    total = float(per_cp.sum())
    overall = rms([d.error_mm for d in found])
    noise = _within_noise(found, overall, floor_mm) if total > 0 else "the model matches every test exactly"
    if noise:
        return noise
    share = per_cp / total
    top = int(np.argmax(share))
    if share[top] >= 0.45:
        where = f"error concentrated at CP{top + 1} ({share[top]:.0%} of the mean distance"
    else:
        where = "error spread over the three contact points (" + ", ".join(
            f"CP{i + 1} {s:.0%}" for i, s in enumerate(share))
    # The distance mixes a lateral part (dilation) with a part along x1 (the block turning: at equal CP1
    # travel, a different rotation moves CP2/CP3 forward or back). Name the lateral part's home separately.
    lateral = np.mean([np.abs(d.lateral_mm).mean(axis=0) for d in found], axis=0)
    lat_share = lateral / max(float(lateral.sum()), 1e-12)
    lat_top = int(np.argmax(lat_share))
    if lat_top != top and lat_share[lat_top] >= 0.45:
        where += (f"; much of it along x1, from the block turning differently), while the lateral (x3) error is "
                  f"concentrated at CP{lat_top + 1} ({lat_share[lat_top]:.0%})")
    else:
        where += ")"
    by_load = [np.mean([d.mean_mm.mean() for d in found if d.force_N == f]) for f in loads]
    if len(loads) >= 3:
        rho = _spearman(np.array(loads), np.array(by_load))
        lo, hi = by_load[0], by_load[-1]
        if rho <= -0.6:
            trend = (f"the error is largest at low load ({lo:.1f} mm at {loads[0]:g} N), shrinking as load grows "
                     f"({hi:.1f} mm at {loads[-1]:g} N)")
        elif rho >= 0.6:
            trend = (f"the error is smallest at low load ({lo:.1f} mm at {loads[0]:g} N), growing with load "
                     f"({hi:.1f} mm at {loads[-1]:g} N)")
        else:
            trend = f"the error shows no clear trend in load ({min(by_load):.1f} to {max(by_load):.1f} mm)"
        sentences += [where, trend]
    else:
        sentences.append(where)
    # Along the travel: compare the last third with the first third of each test.
    early, late = [], []
    for d in found:
        s = d.travel_m
        if s.size < 6 or s.max() <= 0:
            continue
        dist = np.abs(d.lateral_mm).mean(axis=1)
        early.append(dist[s <= s.max() / 3].mean())
        late.append(dist[s >= 2 * s.max() / 3].mean())
    if early and np.mean(late) > 2 * max(np.mean(early), 1e-9):
        sentences.append("it grows along the travel (small at the start, largest at the end)")
    dil = np.mean([d.dilation_error_mm for d in found], axis=0)
    k = int(np.argmax(np.abs(dil)))
    if abs(dil[k]) >= max(0.5, 0.2 * overall):
        more = "more" if dil[k] < 0 else "less"
        sentences.append(f"the model dilates CP{k + 1} {more} toward +x3 than measured (by {abs(dil[k]):.1f} mm on "
                         "average at the end of the travel)")
    rot = np.mean([d.rotation_error_deg for d in found])
    if abs(rot) >= 0.5:
        sense = "counter-clockwise" if rot > 0 else "clockwise"
        sentences.append(f"the measured block turns {abs(rot):.1f} deg more {sense} than the model (seen from above)")
    arr = [d.arrival_error_s for d in found if math.isfinite(d.arrival_error_s)]
    if arr and abs(np.mean(arr)) >= 0.005:
        when = "earlier" if np.mean(arr) < 0 else "later"
        sentences.append(f"the model arrives {abs(np.mean(arr)):.3f} s {when} than measured on average")
    from .evidence import time_domain
    td = time_domain(found)
    if td["mostly_in_time"]:
        # the paths agree better than the timing: lead with the timing (the summary would otherwise hide it)
        sentences.insert(0, f"the error is mostly in time: the model's travel lags the measured by "
                            f"{td['lag_rms_mm']:.2f} mm RMS at equal time, against a mean path distance of "
                            f"{td['mean_distance_mm']:.2f} mm (right path, wrong pace)")
    elif td["lag_rms_mm"] is not None:
        sentences.append(f"in time, the travel lag is {td['lag_rms_mm']:.2f} mm RMS")
    if td["dominant_frequency_hz"] is not None:
        sentences.append(f"the residual oscillates at {td['dominant_frequency_hz']:.1f} Hz (a spectral peak in "
                         f"{td['periodic_fraction']:.0%} of the tests)")
    if status:
        odd = {f: s for f, s in status.items() if s != Outcome.TRAVEL.label}
        for f, s in sorted(odd.items()):
            if s == Outcome.HELD.label:
                thr = (thresholds or {}).get(f)
                extra = f", threshold {thr:.2f} N" if thr else ""
                sentences.append(f"at {f:g} N the model never slides (below its sliding threshold{extra})")
            else:
                sentences.append(f"at {f:g} N the model run ends early ({s})")
    return "; ".join(sentences) + "."


def _within_noise(found: Sequence[TestDiscrepancy], overall: float, floor_mm: float | None) -> str | None:
    """The sentence for an error that noise explains (every run covered its tests), else ``None``."""
    from .evidence import INTEGRATOR_FLOOR_MM, WITHIN_NOISE_FACTOR
    if floor_mm is None or not all(d.outcome is Outcome.TRAVEL for d in found):
        return None
    if not overall <= WITHIN_NOISE_FACTOR * floor_mm:
        return None
    source = ("the integrator's tolerance (the traces show no noise)" if floor_mm <= INTEGRATOR_FLOOR_MM
              else "what the traces' own noise leaves a perfect model")
    return (f"within the noise: the RMS discrepancy, {overall:.2g} mm, is within {WITHIN_NOISE_FACTOR:g} x "
            f"{source}, {floor_mm:.2g} mm; no pattern to describe.")


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    rx, ry = np.argsort(np.argsort(x)), np.argsort(np.argsort(y))
    if np.std(rx) == 0 or np.std(ry) == 0:
        return 0.0
    return float(np.corrcoef(rx, ry)[0, 1])


def compare(tests: Sequence[MeasuredTest], spec: ModelSpec | None = None,
            executor: ExecutorLike = "serial") -> Comparison:
    """Simulate ``spec`` (default: case B) at every load of ``tests`` and measure the discrepancy.

    A model the core refuses raises (the user asked for it); a run that holds or ends early is reported
    per test."""
    spec = spec or ModelSpec()
    tests = list(tests)
    tasks = tasks_for(spec, tests, keep_result=True)
    spec.build(tasks[0].force_N) if tasks else None     # an invalid user model fails here, loudly
    runs = run_tasks(safe_evaluate, tasks, executor)
    by_force = {r.force_N: r for r in runs}
    by_id = {d.test_id: d for r in runs for d in r.discrepancies}
    return Comparison(spec, tests, [by_id[t.test_id] for t in tests], by_force)
