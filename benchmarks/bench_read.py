"""Reading a large measured-trace CSV: time and peak memory of ``read_measurements`` on 500,000 rows.

Run from the repository root::

    PYTHONPATH=. python benchmarks/bench_read.py [--rows 500000]

The file is the shipped ``data/lab_traces.csv`` repeated (each copy's test ids suffixed, so every test is
distinct) up to the row count, written to a temporary folder. The read runs in a fresh process; its peak
resident memory (``VmHWM``, Linux) is reported in all and above the resident memory before the read.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import resource, sys, time
from triplanar.measurement import read_measurements
def vm(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1])
base = vm("VmRSS:")
t0, c0 = time.perf_counter(), time.process_time()
tests = read_measurements(sys.argv[1])
seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
peak = vm("VmHWM:")
print(f"{len(tests)} {sum(t.n_samples for t in tests)} {seconds:.2f} {cpu:.2f} {peak / 1024:.0f} "
      f"{(peak - base) / 1024:.0f}")
"""


def make_file(path: Path, rows: int) -> None:
    lines = (ROOT / "data" / "lab_traces.csv").read_text(encoding="utf-8").splitlines()
    header, body = lines[0], lines[1:]
    out, copy = [header], 0
    while len(out) - 1 < rows:
        for line in body[: rows - (len(out) - 1)]:
            test_id, rest = line.split(",", 1)
            out.append(f"{test_id}-c{copy},{rest}")
        copy += 1
    path.write_text("\n".join(out) + "\n", encoding="utf-8")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=500_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        make_file(path, args.rows)
        size_mb = path.stat().st_size / 1e6
        result = subprocess.run([sys.executable, "-c", CHILD, str(path)], cwd=ROOT, capture_output=True, text=True,
                                check=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    tests, samples, seconds, cpu, peak_mb, read_mb = result.stdout.split()
    print(f"{samples} rows ({size_mb:.0f} MB, {tests} tests): read in {seconds} s ({cpu} s CPU); peak RSS {peak_mb} MB "
          f"({read_mb} MB above the process before the read)")


if __name__ == "__main__":
    main()
