"""Check diagnose's outside-library thresholds on seeded synthetic datasets.

The thresholds (``triplanar/workbench/evidence.py``, ``Diagnoser``): the repeat scatter may exceed what noise and
the specimen explain by ``scatter_factor`` (2) before "random from test to test"; a test's residual is periodic when
its spectral peak above 2 Hz exceeds ``PEAK_FACTOR`` (6) x its median power, and the data have a dominant frequency
when half the tests are; the error is "mostly in time" when the travel lag exceeds ``MOSTLY_IN_TIME`` (10) x the
mean path distance. They were set from a few datasets; this measures them on many, made by the project's own
generator (``triplanar/labdata.py``: 4 loads x 2 repeats, 0.2 mm noise, 0.2 deg friction scatter), several seeds:

* clean data (the model is the truth): every flag raised is a false positive;
* each library effect hidden: scatter and periodic flags are judged after the true model (what diagnose sees after
  the right candidate): false positives; "mostly in time" against case B: expected for the time-mostly effects
  (rate friction, actuator rise), not for the path effects;
* out-of-library effects: a thrust ripple with a random phase per test (30 % at 10 Hz, 40 % at 4 Hz) and a
  steady force ripple (6 N at 6 Hz, locked phase), judged after the library part of the truth: a periodic flag is
  a true positive, its absence a false negative; the scatter flag is reported too.

Only evaluations of given models (no fits), so it runs in a few minutes::

    PYTHONPATH=. python benchmarks/threshold_check.py [--seeds 8]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import ModelSpec, evaluate_spec, repeat_scatter_mm
from triplanar.workbench.evidence import (MOSTLY_IN_TIME, PEAK_FACTOR, expected_scatter_mm, instrument_noise_mm,
                                          systematic_bias, time_domain)
from triplanar.workbench.fit import discrepancies
from triplanar.workbench.scenarios import ForceRipple, ThrustRipple

LOADS = (27.8, 35.0, 45.0, 55.6)
REPEATS = 2


def register_locals() -> None:
    from triplanar import EFFECTS
    EFFECTS[ThrustRipple.name] = ThrustRipple  # (by name, for the worker processes)
    EFFECTS[ForceRipple.name] = ForceRipple


# name -> (data effects (specs), per-test draws, the model the residual flags are judged after, kind)
END = "end_friction:phi_deg=8"
CASES = {
    "clean (case A)": ([END], None, [END], "clean"),
    "clean (case B)": ([], None, [], "clean"),
    "rate_friction a 0.3": (["rate_friction:a=0.3"], None, ["rate_friction:a=0.3"], "time"),
    "actuator_rise 50 ms": (["actuator_rise:tau_s=0.05"], None, ["actuator_rise:tau_s=0.05"], "time"),
    "tip_offset -5 mm": (["tip_offset:offset_m=-0.005"], None, ["tip_offset:offset_m=-0.005"], "path"),
    "plane_tilt dip2 2.5": (["plane_tilt:dip2_deg=2.5"], None, ["plane_tilt:dip2_deg=2.5"], "path"),
    "contact_friction 15/17/10": (["contact_friction:phi1_deg=15,phi2_deg=17,phi3_deg=10"], None,
                                  ["contact_friction:phi1_deg=15,phi2_deg=17,phi3_deg=10"], "path"),
    "cohesion 0.4 N": (["cohesion:c_N=0.4"], None, ["cohesion:c_N=0.4"], "time"),
    "end_friction 8": ([END], None, [END], "path"),
    "ripple 30 % 10 Hz, random phase": ([END, "outside_thrust_ripple:frac=0.3,freq_hz=10"],
                                        {"outside_thrust_ripple": {"phase_rad": (-math.pi, math.pi)}}, [END], "periodic"),
    "ripple 40 % 4 Hz, random phase": ([END, "outside_thrust_ripple:frac=0.4,freq_hz=4"],
                                       {"outside_thrust_ripple": {"phase_rad": (-math.pi, math.pi)}}, [END], "periodic"),
    "ripple 15 % 10 Hz, random phase": ([END, "outside_thrust_ripple:frac=0.15,freq_hz=10"],
                                        {"outside_thrust_ripple": {"phase_rad": (-math.pi, math.pi)}}, [END], "periodic"),
    "force ripple 6 N 6 Hz": ([END, "outside_force_ripple:amp_N=6,freq_hz=6"], None, [END], "periodic"),
    "ripple 30 % 10 Hz, locked phase": ([END, "outside_thrust_ripple:frac=0.3,freq_hz=10,phase_rad=1"], None, [END],
                                        "periodic"),
    # a library effect the judged model lacks (smooth residuals): a periodic flag is a false positive
    "rate_friction a 0.2, vs case A": ([END, "rate_friction:a=0.2"], None, [END], "lacking"),
    "actuator_rise 50 ms, vs case A": ([END, "actuator_rise:tau_s=0.05"], None, [END], "lacking"),
    "cohesion 0.4 N, vs case A": ([END, "cohesion:c_N=0.4"], None, [END], "lacking"),
    "tip_offset -5 mm, vs case A": ([END, "tip_offset:offset_m=-0.005"], None, [END], "lacking"),
    # an instrument bias the judged model lacks: the systematic flag is a true positive, its absence a false negative
    "lateral gain 20 %, vs case A": ([END, "rangefinder_gain:gain_x3=1.2"], None, [END], "bias"),
}


def spec(effects: list[str]) -> ModelSpec:
    return ModelSpec.from_effects([make_effect(e) for e in effects])


def peak_ratios(found) -> list[float]:
    """Each test's spectral peak over its median power (above 2 Hz), where it has a spectrum."""
    from triplanar.workbench.evidence import F_MIN_HZ, residual_spectrum
    out = []
    for d in found:
        s = residual_spectrum(d)
        if s is None:
            continue
        f, p = s
        band = f >= F_MIN_HZ
        if band.sum() >= 4 and np.any(p[band] > 0):
            out.append(float(p[band].max() / np.median(p[band])))
    return out


def measure(name: str, seed: int) -> dict:
    data, per_test, after, kind = CASES[name]
    tests, truth = generate_lab_data(loads=LOADS, repeats=REPEATS, seed=seed, effects=[make_effect(e) for e in data],
                                     per_test=per_test)
    rest = spec([]).rest_positions
    judged = spec(after)
    def evaluate(s, ts):
        return discrepancies(evaluate_spec(s, ts))
    noise = instrument_noise_mm(tests)
    expected = expected_scatter_mm(judged, tests, noise, 0.2, evaluate)
    scatter = repeat_scatter_mm(tests, rest)
    after_found = evaluate(judged, tests)
    td_after = time_domain(after_found)
    td_b = time_domain(evaluate(spec([]), tests))
    return {"scatter_ratio": scatter / expected, "systematic": systematic_bias(after_found), "periodic_fraction": td_after["periodic_fraction"],
            "dominant_hz": td_after["dominant_frequency_hz"], "peaks": peak_ratios(after_found),
            "time_ratio_B": (td_b["lag_rms_mm"] or math.nan) / td_b["mean_distance_mm"],
            "n_tests": len(tests), "skipped": len(truth["skipped"])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--first-seed", type=int, default=200)
    parser.add_argument("--full", action="store_true", help="12 loads x 4 repeats (48 tests) instead of 4 x 2")
    parser.add_argument("--cases", help="only the kinds of data whose name contains this")
    args = parser.parse_args()
    global LOADS, REPEATS
    if args.full:
        from triplanar import PAPER_LOADS_N
        LOADS, REPEATS = PAPER_LOADS_N, 4
    register_locals()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    began = time.perf_counter()
    names = [n for n in CASES if not args.cases or args.cases in n]
    print(f"{len(names)} kinds x {args.seeds} seeds ({seeds.start}-{seeds.stop - 1}), {len(LOADS)} loads x {REPEATS} "
          f"repeats; "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"{'data':34s} {'kind':8s} {'scatter/expected':>22s} {'>2x':>4s} {'periodic frac':>14s} {'dominant':>9s} "
          f"{'peak/median (max; median)':>26s} {'lag/dist B (min-max)':>22s} {'>10x':>5s}")
    for name in names:
        rows = [measure(name, s) for s in seeds]
        kind = CASES[name][3]
        sr = np.array([r["scatter_ratio"] for r in rows])
        pf = np.array([r["periodic_fraction"] for r in rows])
        dom = sum(r["dominant_hz"] is not None for r in rows)
        peaks = [p for r in rows for p in r["peaks"]]
        tr = np.array([r["time_ratio_B"] for r in rows])
        freqs = [r["dominant_hz"] for r in rows if r["dominant_hz"] is not None]
        anyflag = sum((r["scatter_ratio"] > 2) or (r["dominant_hz"] is not None) for r in rows)
        print(f"{name:34s} {kind:8s} {np.median(sr):6.2f} ({sr.min():4.2f}-{sr.max():5.2f}) "
              f"{int((sr > 2).sum()):3d}/{len(rows)} {np.mean(pf):6.0%} (max {pf.max():3.0%}) "
              f"{dom:3d}/{len(rows)}{'' if not freqs else f' ~{np.median(freqs):.1f} Hz':>0s} "
              f"{max(peaks) if peaks else math.nan:8.1f}; {np.median(peaks) if peaks else math.nan:5.1f} "
              f"{(np.array(peaks) > PEAK_FACTOR).mean() if peaks else math.nan:5.0%}>{PEAK_FACTOR:g} "
              f"{tr.min():7.1f}-{tr.max():6.1f} {int((tr > MOSTLY_IN_TIME).sum()):3d}/{len(rows)}   "
              f"scatter or periodic flag: {anyflag}/{len(rows)}; systematic flag: "
              f"{sum(r['systematic']['systematic'] for r in rows)}/{len(rows)} (smallest p "
              f"{min(r['systematic']['p_value_all'] for r in rows):.2g})", flush=True)
    print(f"({time.perf_counter() - began:.0f} s; load average {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
