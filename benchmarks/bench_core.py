"""Core-model speed: one 8 cm trace (case A, the 12 paper loads) and one fixed-step control step.

Run: ``.venv/bin/python benchmarks/bench_core.py`` (or ``make bench``). Prints medians over repeats, the
trace's accuracy against a much tighter solution, and where a trace's time goes. One process, one core.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from triplanar import PAPER_LOADS_N, paper_model, simulate
from triplanar import kernel as K, stepping
from triplanar.outcome import Outcome
from triplanar.statics import holds, start_motion


def _median_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_traces(repeats: int = 20) -> None:
    print("case A, one 8 cm trace (simulate with default tolerances, rtol=1e-8)")
    print(f"{'F_T (N)':>8} {'median ms':>10} {'LP ms':>7} {'steps':>6} {'max error vs tight (m)':>23}")
    totals, lps = [], []
    for force in PAPER_LOADS_N:
        model = paper_model("A", force)
        result = simulate(model)
        total = _median_time(lambda: simulate(model), repeats)
        y0 = model.initial_state()
        lp = _median_time(lambda: holds(model, y0), repeats)
        tight = simulate(model, rtol=1e-12, atol=1e-15)
        travels = np.linspace(0.0, 0.08, 81)
        error = np.abs(result.resample_by_travel(travels) - tight.resample_by_travel(travels)).max()
        totals.append(total)
        lps.append(lp)
        print(f"{force:8.1f} {total * 1e3:10.2f} {lp * 1e3:7.2f} {len(result.t):6d} {error:23.2e}")
    print(f"median over loads: {statistics.median(totals) * 1e3:.2f} ms per trace, of which the static-equilibrium "
          f"LP {statistics.median(lps) * 1e3:.2f} ms")


def bench_control_step(repeats: int = 2000) -> None:
    print("\ncase A, one control step: 5 ms of physical time, RK4, 1 substep (stepping.integrate_ws from Python, "
          "record=False, one workspace as the env keeps)")
    medians = []
    for force in PAPER_LOADS_N:
        model = paper_model("A", force)
        p, y0 = model.kernel_params(), model.initial_state()
        modes = K.sliding_modes()
        start_motion(p, modes, y0)
        armed = np.zeros(5, np.bool_)
        bufs = (np.empty(1), np.empty((1, K.N_STATE)), np.empty((1, K.N_STATE)), np.empty((1, K.N_AUX)))
        ws = stepping.new_workspace()
        K.modes_of(ws)[:] = modes
        rec = stepping.Recording(False, *bufs, np.empty((0, 3)))
        x1_target = model.specimen.contact_points_m[0, 0] + 0.08
        y, t = y0.copy(), 0.0
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            opts = stepping.StepOptions(stepping.METHOD_RK4, 0.0, 0.0, t + 0.005, x1_target, 1e-5, 0.0)
            status, _, _, _, t = stepping.integrate_ws(t, y, p, armed, 0.005, opts, rec, 0, ws)
            times.append(time.perf_counter() - t0)
            if status != Outcome.TIME_LIMIT:  # travel reached: start the episode again
                y, t = y0.copy(), 0.0
                armed[:] = False
        medians.append(statistics.median(times))
    print(f"median over loads: {statistics.median(medians) * 1e6:.2f} us per control step "
          f"(range {min(medians) * 1e6:.2f}-{max(medians) * 1e6:.2f})")


if __name__ == "__main__":
    simulate(paper_model("A", 30.0))  # compile (or load numba's cache) before timing
    bench_traces()
    bench_control_step()
