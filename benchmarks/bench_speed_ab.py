"""Kernel and env speed of any checkout, in this thread's CPU time, for before/after comparisons of a change.

Run it from the checkout to measure (it imports that checkout's ``benchmarks/bench_env.py``), alternating the
two checkouts, each pinned to one core::

    cd OLD && taskset -c 1 env PYTHONPATH=. python /path/to/benchmarks/bench_speed_ab.py before
    cd NEW && taskset -c 1 env PYTHONPATH=. python /path/to/benchmarks/bench_speed_ab.py after

Prints, best of a few repeats: the kernel floor (one 5 ms RK4 period in a compiled loop), the single env with
random and constant actions, and the vector env at 4096 envs with constant and random actions (steps per second
of CPU time: a shared machine's other work slows wall time far more than it slows the thread's own time).
"""

from __future__ import annotations

import sys
import time


def main() -> None:
    import benchmarks.bench_env as B  # the checkout under test (PYTHONPATH=.)
    B.kernel_floor(1000)  # compiled code loaded before timing
    # the benchmark's timer -> this thread's CPU time (bench_env reads its clock from CLOCK, bound when it was
    # imported: replacing time.perf_counter here would leave it timing wall time)
    B.CLOCK[0] = time.thread_time
    stats: dict = {}
    out = {"kernel floor, periods/s": max(B.kernel_floor(50000) for _ in range(5)),
           "single env random, steps/s": max(B.single(20000, "random", stats) for _ in range(3)),
           "single env constant, steps/s": max(B.single(20000, "constant", stats) for _ in range(3)),
           "vector env 4096 constant, env-steps/s": max(B.vector(4096, 30, "constant") for _ in range(3)),
           "vector env 4096 random, env-steps/s": max(B.vector(4096, 30, "random") for _ in range(3))}
    label = sys.argv[1] if len(sys.argv) > 1 else "this checkout"
    print(label + ": " + "; ".join(f"{k} {v:,.0f}" for k, v in out.items()), flush=True)


if __name__ == "__main__":
    main()
