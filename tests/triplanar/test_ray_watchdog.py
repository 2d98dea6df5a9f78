"""A killed command leaves no Ray process behind: the watchdog (triplanar.ray_watchdog) ends a dead driver's Ray
processes, and only those."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from triplanar import ray_watchdog

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="the watchdog reads /proc (Linux)")

GONE_WITHIN_S = 10.0   # the watchdog polls every POLL_S (1 s); margin for a loaded machine. Ray alone: about 60 s


def _wait_gone(pids: list[int], within_s: float) -> list[int]:
    deadline = time.monotonic() + within_s
    while True:
        left = [pid for pid in pids if ray_watchdog._stat(pid) is not None and ray_watchdog._stat(pid)[1] != "Z"]
        if not left or time.monotonic() > deadline:
            return left
        time.sleep(0.1)


def test_a_dead_drivers_ray_processes_are_killed_and_its_other_children_are_not() -> None:
    # a driver with a child named as Ray names its workers, and an unrelated child
    driver = subprocess.Popen(["bash", "-c", "(exec -a ray::FakeWorker sleep 300) & echo $!; sleep 300 & echo $!; "
                                             "wait"], stdout=subprocess.PIPE, text=True)
    fake_ray, other = int(driver.stdout.readline()), int(driver.stdout.readline())
    watchdog = subprocess.Popen([sys.executable, "-I", ray_watchdog.__file__, str(driver.pid)],
                                stdout=subprocess.PIPE, text=True)
    try:
        assert select.select([watchdog.stdout], [], [], 60)[0], "the watchdog said nothing in 60 s"
        watched = watchdog.stdout.readline().split()   # "watching PID ...": the fake worker recorded
        assert watched[0] == "watching" and str(fake_ray) in watched and str(other) not in watched
        driver.kill()
        driver.wait()
        assert _wait_gone([fake_ray], GONE_WITHIN_S) == []
        assert watchdog.wait(GONE_WITHIN_S) == 0
        assert _wait_gone([other], 0.0) == [other]   # not Ray's: left alone
    finally:
        for pid in (fake_ray, other):
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        watchdog.kill()


DRIVER = """
import sys, time
from pathlib import Path
from triplanar.executor import run_tasks
from triplanar.ray_executor import RayExecutor

def wait_here(job):
    folder, x = job
    Path(folder, f"started_{x}").touch()
    time.sleep(300)

with RayExecutor(num_cpus=2) as executor:
    run_tasks(wait_here, [(sys.argv[1], 0), (sys.argv[1], 1)], executor)
"""


@pytest.mark.long   # a real Ray started by a command: about 20 s of start-up on this machine
@pytest.mark.xdist_group("ray")
def test_a_sigkilled_ray_command_leaves_no_ray_process(tmp_path) -> None:
    pytest.importorskip("ray")
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]),
               RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0")
    driver = subprocess.Popen([sys.executable, "-c", DRIVER, str(tmp_path)], env=env, cwd=tmp_path)
    deadline = time.monotonic() + 300
    while len(list(tmp_path.glob("started_*"))) < 2:
        assert driver.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    ray_processes = list(ray_watchdog.ray_descendants(driver.pid))
    assert any(ray_watchdog._is_ray(pid) for pid in ray_processes) and len(ray_processes) >= 4   # workers, agents
    driver.send_signal(signal.SIGKILL)
    driver.wait()
    left = _wait_gone(ray_processes, GONE_WITHIN_S)
    for pid in left:   # clean up before failing
        os.kill(pid, signal.SIGKILL)
    assert left == [], f"Ray processes still running {GONE_WITHIN_S:g} s after the command was killed"
