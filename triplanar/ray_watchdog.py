"""A watchdog that ends a local Ray's processes when the command that started it dies without shutting it down
(SIGKILL, the out-of-memory killer).

Why: Ray ties its raylet and GCS to the driver (they die with it), and its workers follow the raylet within seconds,
but the dashboard and runtime-env agents, on finding the raylet dead, first try to report to the (dead) GCS and wait
out Ray's fixed 60 s timeout (``ray._private.utils.publish_error_to_driver``): two processes outlived a killed
``triplanar`` command by about a minute. :class:`triplanar.ray_executor.RayExecutor` starts this watchdog beside a
Ray it starts itself (never for a cluster it joins) and stops it after ``ray.shutdown()``.

The watchdog is its own small process (``python -I ray_watchdog.py DRIVER_PID``, standard library only, so it starts
in milliseconds and imports nothing of the project). Every ``POLL_S`` seconds it records the driver's descendants that
are Ray's (``ray::...`` workers and agents, programs and scripts under a ``ray/`` folder) with their start times;
once the driver is gone (no process, a zombie, or a new process under its id) it sends SIGKILL to each recorded one
still running (same id and start time) and exits. So every Ray process the driver started is gone within about
``POLL_S`` seconds of the driver's death (the test: ``tests/triplanar/test_ray_watchdog.py``). Linux only (``/proc``);
elsewhere the watchdog exits at once and Ray's own timeouts apply.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

POLL_S = 1.0


def _stat(pid: int) -> tuple[int, str, int] | None:
    """(parent id, state letter, start time in clock ticks) of process ``pid``, or None if there is none."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            text = f.read().decode(errors="replace")
    except OSError:
        return None
    fields = text.rpartition(")")[2].split()   # after the command name, which may hold spaces and parentheses
    return int(fields[1]), fields[0], int(fields[19])


def _is_ray(pid: int) -> bool:
    """A Ray process: a worker or agent (``ray::NAME``) or a program or script under a ``ray/`` folder (raylet,
    gcs_server, log_monitor.py, dashboard.py, ...)."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            args = f.read().decode(errors="replace").split("\0")
    except OSError:
        return False
    return args[0].startswith("ray::") or any("/ray/" in a for a in args[:2])


def ray_descendants(driver: int) -> dict[int, int]:
    """{pid: start time} of the Ray processes among ``driver``'s descendants."""
    children: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if name.isdigit():
            stat = _stat(int(name))
            if stat is not None:
                children.setdefault(stat[0], []).append(int(name))
    found, todo = {}, list(children.get(driver, []))
    while todo:
        pid = todo.pop()
        todo.extend(children.get(pid, []))
        stat = _stat(pid)
        if stat is not None and pid != os.getpid() and _is_ray(pid):
            found[pid] = stat[2]
    return found


def alive(pid: int, started: int) -> bool:
    """Process ``pid`` runs and is the one that started at ``started`` (not a zombie, not a reused id)."""
    stat = _stat(pid)
    return stat is not None and stat[1] != "Z" and stat[2] == started


def watch(driver: int, poll_s: float = POLL_S) -> list[int]:
    """Record ``driver``'s Ray descendants until it is gone, then kill those still running; returns their ids."""
    stat = _stat(driver)
    if stat is None:
        return []
    driver_started, seen = stat[2], {}
    while alive(driver, driver_started):
        found = ray_descendants(driver)
        if set(found) - set(seen):   # said on stdout (the executor discards it; a test reads it)
            print("watching", *sorted(set(seen) | set(found)), flush=True)
        seen.update(found)
        seen = {pid: t for pid, t in seen.items() if alive(pid, t)}
        time.sleep(poll_s)
    killed = []
    for pid, started in seen.items():
        if alive(pid, started):
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except OSError:   # gone meanwhile
                pass
    return killed


def start(driver: int | None = None) -> subprocess.Popen | None:
    """The watchdog process for ``driver`` (default: this process); None where there is no ``/proc``. Stop it with
    ``terminate()`` once Ray is shut down."""
    if not os.path.isdir("/proc/self"):
        return None
    return subprocess.Popen([sys.executable, "-I", __file__, str(driver or os.getpid())],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL)


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C reaches the whole process group: outlive it to clean up
    watch(int(sys.argv[1]))
