"""Workbench speed: compare, diagnose and fit on the shipped laboratory dataset (48 tests).

Run from the repository root::

    PYTHONPATH=. python benchmarks/bench_workbench.py             # speed on data/lab_traces.csv
    PYTHONPATH=. python benchmarks/bench_workbench.py --hidden    # + each built-in effect hidden in 48 tests

Diagnose runs as the command does: a 2-process pool (``--workers``), 3 folds over load levels, a progress bar
on stderr. ``--hidden`` makes, for every built-in effect, a 48-test dataset (12 loads x 4 repeats, seed 1) with
that effect and none other, diagnoses it against case B and prints rank, parameter error and error fall
(about 3 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from triplanar import make_effect
from triplanar.workbench import Diagnoser, EffectFit, ModelSpec, compare, evaluate_spec, load_tests
from triplanar.workbench.scenarios import HIDDEN_EFFECTS

HIDDEN = HIDDEN_EFFECTS  # effect -> (data spec, parameters to recover within 15 %)


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def cpu_seconds() -> float:
    """CPU time of this process and its finished children (the pool's workers, once shut down)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def bench_speed(data: Path, workers: int) -> None:
    tests = load_tests(data)
    print(f"dataset {data.relative_to(ROOT) if data.is_relative_to(ROOT) else data}: {len(tests)} tests, "
          f"{sum(t.n_samples for t in tests)} samples, {len({t.shear_force_N for t in tests})} loads; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}")
    base = ModelSpec()
    evaluate_spec(base, tests)                       # warm up (numba cache, imports)
    times = [timed(lambda: evaluate_spec(base, tests))[1] for _ in range(5)]
    print(f"one evaluation of case B on all 48 tests (12 simulations + discrepancies, one process): "
          f"{statistics.median(times) * 1e3:.0f} ms median of 5")
    cmp, t_cmp = timed(lambda: compare(tests, base))
    print(f"compare (case B): {t_cmp:.2f} s; RMS discrepancy {cmp.error_mm:.2f} mm")
    cpu0, wall0 = cpu_seconds(), time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        diag, t_diag = timed(lambda: Diagnoser(executor=pool if workers > 1 else "serial").fit(tests, base))
    cpu, wall = cpu_seconds() - cpu0, time.perf_counter() - wall0
    r = diag.report_
    print(f"diagnose ({workers} worker{'s' if workers > 1 else ''}, {len(diag.folds_)} folds, intervals, noise and "
          f"time-domain evidence included): {t_diag:.1f} s wall ({wall:.1f} s with the pool's start and shutdown), "
          f"{cpu:.1f} s CPU (this process and its workers); load average {os.getloadavg()[0]:.2f} -> "
          f"{r['verdict']}, {r['missing_effect']} ({r['confidence']}); baseline {r['baseline_error_mm']:.2f} mm, "
          f"repeat scatter {r['repeat_scatter_mm']:.2f} mm, noise {r['noise']['instrument_noise_mm']:.3f} mm, "
          f"expected scatter {r['noise']['expected_scatter_mm']:.3f} mm")
    for c in diag.candidates_:
        params = ", ".join(f"{k} = {v:.4g} {c.param_ci95[k] and '[%.4g, %.4g]' % tuple(c.param_ci95[k])}"
                           for k, v in c.params.items())
        print(f"   {c.effect:17s} cv {c.cv_error_mm:7.3f} mm  improvement {c.improvement:6.1%}  "
              f"fits {c.seconds:5.1f} s CPU ({c.nfev} evaluations)  {params}{'' if c.plausible else '  [implausible]'}")
    fit, t_fit = timed(lambda: EffectFit(["end_friction"]).fit(tests, base))
    print(f"fit --add end_friction ({workers} workers): {t_fit:.1f} s; phi = "
          f"{fit.params_['end_friction']['phi_deg']:.3f} +- {fit.stderr_['end_friction']['phi_deg']:.3f} deg; "
          f"error {fit.baseline_error_mm_:.2f} -> {fit.error_mm_:.3f} mm")


def bench_hidden(workers: int) -> None:
    from triplanar.labdata import generate_lab_data
    print("\nhidden effects, 48 tests each (12 loads x 4 repeats, seed 1), diagnosed against case B:")
    print(f"{'hidden':17s} {'rank':>4s} {'named (confidence)':26s} {'fall':>6s} parameters: fitted (truth, error)")
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for name, (spec, truth) in HIDDEN.items():
            tests, _ = generate_lab_data(effects=[make_effect(spec)], seed=1)
            diag, seconds = timed(lambda: Diagnoser(executor=pool, progress=False).fit(tests))
            ranks = [c.effect for c in diag.candidates_]
            mine = diag.candidates_[ranks.index(name)]
            errs = ", ".join(f"{p} {mine.params[p]:.4g} ({v:g}, {abs(mine.params[p] - v) / abs(v):.1%})"
                             for p, v in truth.items())
            named = f"{diag.missing_effect_} ({diag.confidence_})"
            print(f"{name:17s} {ranks.index(name) + 1:4d} {named:26s} "
                  f"{mine.improvement:6.1%} {errs}   [{seconds:.0f} s; runner-up "
                  f"{diag.candidates_[1 if ranks[0] == name else 0].effect}]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=ROOT / "data" / "lab_traces.csv")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--hidden", action="store_true", help="also the hidden-effect table on 48-test datasets")
    args = parser.parse_args()
    bench_speed(args.data, args.workers)
    if args.hidden:
        bench_hidden(args.workers)


if __name__ == "__main__":
    main()
