"""Per-task overhead of the Ray backend and the size of a diagnose task (for docs/scaling.md).

    PYTHONPATH=. python benchmarks/bench_ray_overhead.py

Starts a local Ray (2 CPUs, 127.0.0.1), runs 400 empty tasks through ``run_tasks`` (after a warm-up round) and
prints the wall time per task; then pickles one diagnose task of data/lab_traces.csv and its result.
"""

from __future__ import annotations

import os
import time

import cloudpickle

from triplanar.executor import run_tasks
from triplanar.ray_executor import RayExecutor


def nothing(x: int) -> int:
    return x


def one_simulation(force_N: float) -> str:
    from triplanar import paper_model, simulate
    return simulate(paper_model("A", force_N)).status.label


def main() -> None:
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    with RayExecutor(num_cpus=2) as ex:
        for what in ("cold", "warm"):  # first: each worker imports triplanar and loads numba's cache
            started = time.perf_counter()
            run_tasks(one_simulation, [32.5, 32.5], ex)
            print(f"2 simulations on 2 {what} workers: {time.perf_counter() - started:.2f} s")
        run_tasks(nothing, list(range(20)), ex)  # workers up
        for n in (400,):
            started = time.perf_counter()
            run_tasks(nothing, list(range(n)), ex)
            print(f"{n} empty tasks: {1e3 * (time.perf_counter() - started) / n:.2f} ms per task (wall, 2 CPUs)")
    from pathlib import Path

    from triplanar.workbench.candidates import resolve
    from triplanar.workbench.compare import load_tests
    from triplanar.workbench.diagnose import CandidateTask, load_folds
    from triplanar.workbench.spec import ModelSpec
    tests = load_tests(Path(__file__).resolve().parents[1] / "data" / "lab_traces.csv")
    folds = load_folds([t.shear_force_N for t in tests], 3)
    task = CandidateTask(ModelSpec(), resolve(["end_friction"])[0], tuple(tests), tuple(tuple(f) for f in folds), 30,
                         (), {})
    print(f"one diagnose task (48 tests): {len(cloudpickle.dumps(task)) / 1e3:.0f} kB pickled")
    from triplanar.workbench.diagnose import run_candidate
    started = time.perf_counter()
    result = run_candidate(task)
    print(f"its result: {len(cloudpickle.dumps(result)) / 1e3:.1f} kB, computed in {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
