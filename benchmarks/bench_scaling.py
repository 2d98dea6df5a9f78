"""Speed-up of a sweep from 1 to 2 CPUs, per backend: the same diagnose run (data/lab_traces.csv, every candidate)
with ``--workers 1`` and ``--workers 2`` (a local pool of that many processes, or a local Ray with that many CPUs).

    PYTHONPATH=. python benchmarks/bench_scaling.py [--executor local ray] [--repeats 1]

Prints one row per run: wall seconds, CPU seconds of the command and the processes it started (reaped children:
the pool's workers; Ray's workers and daemons, if the command's Ray reaped them), and how busy the machine's CPUs were over the run (from /proc/stat: the
machine is shared, so a busy machine explains a low ratio), then the 1-to-2 ratio per backend. Recorded in
docs/scaling.md. The reports of all runs are checked to be the same (timing fields aside).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cpu_times() -> tuple[int, int]:
    """(busy, total) jiffies of all CPUs of the machine."""
    fields = [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    idle = fields[3] + fields[4]
    return sum(fields) - idle, sum(fields)


def children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(executor: str, workers: int, out: Path) -> tuple[float, float, float]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0")
    env.pop("RAY_ADDRESS", None)
    cmd = [sys.executable, "-m", "triplanar.cli", "diagnose", str(ROOT / "data" / "lab_traces.csv"), "--out",
           str(out), "--no-progress", "--executor", executor, "--workers", str(workers)]
    busy0, total0 = cpu_times()
    cpu0 = children_cpu_s()
    started = time.perf_counter()
    subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True)
    wall = time.perf_counter() - started
    busy1, total1 = cpu_times()
    return wall, (busy1 - busy0) / max(1, total1 - total0), children_cpu_s() - cpu0


def report(path: Path) -> dict:
    data = json.loads(path.read_text())
    data.pop("seconds")
    for c in data["candidates"]:
        c.pop("fit_seconds")
    return data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--executor", nargs="+", default=["local", "ray"])
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} CPUs, load average before {os.getloadavg()[0]:.2f}")
    reports = []
    with tempfile.TemporaryDirectory() as tmp:
        for executor in args.executor:
            walls = {}
            for workers in (1, 2):
                best = None
                for r in range(args.repeats):
                    out = Path(tmp) / f"{executor}-{workers}-{r}"
                    wall, busy, cpu = run(executor, workers, out)
                    reports.append(report(out / "diagnose.json"))
                    print(f"{executor:6s} {workers} CPU(s)  wall {wall:6.1f} s  CPU of the run {cpu:6.1f} s  "
                          f"machine CPUs busy {busy:4.0%}")
                    best = wall if best is None else min(best, wall)
                walls[workers] = best
            print(f"{executor:6s} speed-up 1 -> 2 CPUs: {walls[1] / walls[2]:.2f}x")
    print("reports identical:", all(r == reports[0] for r in reports))


if __name__ == "__main__":
    main()
