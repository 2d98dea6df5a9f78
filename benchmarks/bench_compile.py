"""Compile time from an empty numba cache: ``PYTHONPATH=. python benchmarks/bench_compile.py [--warm-only]``.

Points numba at a fresh temporary cache (``NUMBA_CACHE_DIR``), then runs, each in a new process and in this order
(as a new user would meet them):

1. the first ``simulate`` (case A, 30 N: the statics LP, the start modes and DOPRI5);
2. the first single-env step (``gym.make("TriPlanarShear-v0")``, ``reset``, one ``step``);
3. the first vector-env step (``gym.make_vec(..., num_envs=4)``, ``reset``, one ``step``);

and then the same three again with the cache now warm. Prints, per stage, the wall time of the work (imports
excluded, they are printed apart) and the process's CPU time (user + sys, imports included), which the load of
a shared machine disturbs less than wall time.
"""

from __future__ import annotations

import argparse
import json
import os
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


def run_stage(name: str, cache_dir: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, PYTHONPATH=str(ROOT))
    code = _PRELUDE + STAGES[name] + _EPILOGUE
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        raise SystemExit(f"{name} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    args = parser.parse_args()
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
