"""Compile time from an empty numba cache: ``PYTHONPATH=. python benchmarks/bench_compile.py [--ab A B]``.

Points numba at a fresh temporary cache (``NUMBA_CACHE_DIR``), then runs, each in a new process and in this order
(as a new user would meet them):

1. the first ``simulate`` (case A, 30 N: the statics LP, the start modes and DOPRI5);
2. the first single-env step (``gym.make("TriPlanarShear-v0")``, ``reset``, one ``step``);
3. the first vector-env step (``gym.make_vec(..., num_envs=4)``, ``reset``, one ``step``);

and then the same three again with the cache now warm. Prints, per stage, the wall time of the work (imports
excluded, they are printed apart) and the process's CPU time (user + sys, imports included), which the load of
a shared machine disturbs less than wall time.

``--ab A B --rounds N`` compares two checkouts (folders with the code, e.g. a ``git worktree`` or a ``git archive``
of the baseline): N rounds, each running the three empty-cache stages of A and of B (a fresh cache each), the
order alternating from round to round (AB, BA, ...) so that a drift of the machine's load falls on both alike.
Prints each run's CPU seconds, then the paired difference B - A: its mean with a 95 % interval (Student's t over
the rounds' differences), also as a percentage of A's mean.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from triplanar.atomic import write_atomic

ROOT = Path(__file__).resolve().parents[1]

_PRELUDE = """
import json, resource, sys, time
t0 = time.perf_counter()
import numpy as np
"""
_EPILOGUE = """
t2 = time.perf_counter()
ru = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"import_s": t1 - t0, "work_s": t2 - t1, "cpu_s": ru.ru_utime + ru.ru_stime}))
"""
STAGES = {
    "simulate": """
from triplanar import paper_model, simulate
from triplanar.outcome import Outcome
t1 = time.perf_counter()
assert simulate(paper_model("A", 30.0)).status is Outcome.TRAVEL
""",
    "env step": """
import gymnasium as gym
import envs
t1 = time.perf_counter()
with envs.v0_on_purpose():
    env = gym.make("TriPlanarShear-v0")
env.reset(seed=0)
env.step(np.zeros(2, np.float32))
""",
    "vector env step": """
import gymnasium as gym
import envs
t1 = time.perf_counter()
with envs.v0_on_purpose():
    vec = gym.make_vec("TriPlanarShear-v0", num_envs=4)
vec.reset(seed=0)
vec.step(np.zeros((4, 2), np.float32))
""",
}


def run_stage(name: str, cache_dir: str, root: Path = ROOT) -> dict:
    """One stage in a new process running the code in ``root``, numba caching into ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, PYTHONPATH=str(root))
    code = _PRELUDE + STAGES[name] + _EPILOGUE
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=root)
    if out.returncode != 0:
        raise SystemExit(f"{name} in {root} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def empty_cache_cpu(root: Path) -> float:
    """CPU seconds of the three stages from an empty cache, for the code in ``root``."""
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache_dir:
        return sum(run_stage(name, cache_dir, root)["cpu_s"] for name in STAGES)


def paired_interval(a: list[float], b: list[float]) -> tuple[float, float]:
    """Mean of the paired differences b - a and the half-width of its 95 % interval (Student's t)."""
    from scipy.stats import t as student_t

    d = [y - x for x, y in zip(a, b)]
    if len(d) < 2:
        raise ValueError("--rounds: a paired interval needs at least 2 rounds")
    return statistics.mean(d), student_t.ppf(0.975, len(d) - 1) * statistics.stdev(d) / math.sqrt(len(d))


def compare(a_root: Path, b_root: Path, rounds: int, json_path: Path | None) -> None:
    """Alternating A/B rounds of :func:`empty_cache_cpu`, then the paired difference."""
    for root in (a_root, b_root):
        if not (root / "triplanar" / "kernel.py").is_file():
            raise SystemExit(f"--ab: {root} holds no checkout (no triplanar/kernel.py)")
    cpu: dict[str, list[float]] = {"A": [], "B": []}
    for i in range(rounds):
        for label in ("AB" if i % 2 == 0 else "BA"):
            cpu[label].append(empty_cache_cpu(a_root if label == "A" else b_root))
            print(f"round {i + 1} {label}: {cpu[label][-1]:.2f} s CPU   (load average "
                  f"{os.getloadavg()[0]:.1f})", flush=True)
    mean, half = paired_interval(cpu["A"], cpu["B"])
    mean_a = statistics.mean(cpu["A"])
    print(f"A {a_root}: mean {mean_a:.2f} s CPU ({', '.join(f'{x:.1f}' for x in cpu['A'])})")
    print(f"B {b_root}: mean {statistics.mean(cpu['B']):.2f} s CPU ({', '.join(f'{x:.1f}' for x in cpu['B'])})")
    print(f"B - A: {mean:+.2f} s CPU, 95 % interval [{mean - half:+.2f}, {mean + half:+.2f}] "
          f"({100 * mean / mean_a:+.1f} % [{100 * (mean - half) / mean_a:+.1f}, {100 * (mean + half) / mean_a:+.1f}])")
    if json_path:
        record = {"A": str(a_root), "B": str(b_root), "cpu_s": cpu, "mean_diff_s": mean, "ci95_half_s": half}
        write_atomic(json_path, lambda tmp: tmp.write_text(json.dumps(record, indent=1)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    parser.add_argument("--ab", nargs=2, type=Path, metavar=("A", "B"),
                        help="compare the empty-cache CPU time of two checkouts in alternating rounds")
    parser.add_argument("--rounds", type=int, default=5, help="rounds of --ab (default 5)")
    args = parser.parse_args()
    if args.ab:
        compare(args.ab[0].resolve(), args.ab[1].resolve(), args.rounds, args.json)
        return
    rows = []
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache_dir:
        for cache in ("empty", "warm"):
            for name in STAGES:
                r = run_stage(name, cache_dir)
                rows.append({"cache": cache, "stage": name, **r})
                print(f"{cache:>5} cache  {name:<16} work {r['work_s']:7.2f} s wall   process {r['cpu_s']:7.2f} s CPU"
                      f"   (imports {r['import_s']:.2f} s wall)", flush=True)
    for cache in ("empty", "warm"):
        sel = [r for r in rows if r["cache"] == cache]
        print(f"{cache} cache, total: work {sum(r['work_s'] for r in sel):.2f} s wall, "
              f"{sum(r['cpu_s'] for r in sel):.2f} s CPU")
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.json:
        write_atomic(args.json, lambda tmp: tmp.write_text(json.dumps(rows, indent=1)))


if __name__ == "__main__":
    main()
