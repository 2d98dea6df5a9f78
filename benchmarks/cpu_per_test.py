"""A pytest plugin: each test's CPU and wall seconds, appended to the file named by ``CPU_PER_TEST_LOG`` as the test
finishes (so that a run on a loaded machine, or one stopped early, still tells which tests cost the most).

    CPU_PER_TEST_LOG=cpu.tsv PYTHONPATH=.:benchmarks .venv/bin/python -m pytest -q -p cpu_per_test -n 2 \\
        --dist loadgroup -m "not long"
    sort -rn cpu.tsv | head -20

A row: CPU seconds (setup, call and teardown; this process and the child processes it waited for, so not a Ray
cluster's daemons), wall seconds, the test's id, the Unix time it ended. CPU seconds are what a shared machine
disturbs least: wall seconds there grow with the load, CPU seconds much less.
"""

from __future__ import annotations

import os
import resource
import time

import pytest


def _cpu_s() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    wall, cpu = time.perf_counter(), _cpu_s()
    yield
    path = os.environ.get("CPU_PER_TEST_LOG")
    if path:
        with open(path, "a") as f:
            f.write(f"{_cpu_s() - cpu:.2f}\t{time.perf_counter() - wall:.2f}\t{item.nodeid}\t{time.time():.0f}\n")
