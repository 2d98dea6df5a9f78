"""Shared by the Ray tests: loopback-only Ray settings, task functions that record where and how often they ran,
a diagnose report without its timing fields."""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # every Ray process binds to 127.0.0.1 only

ROOT = Path(__file__).resolve().parents[2]
OBJECT_STORE_BYTES = 100 * 1024 ** 2


def by_value(module_name: str) -> None:
    """Ship a test module's functions to Ray workers by value (the tests folder is not on the workers' path)."""
    import cloudpickle
    cloudpickle.register_pickle_by_value(sys.modules[module_name])


def ray_env() -> dict[str, str]:
    """The environment of a subprocess (a command, a Ray node): this worktree first on the path, loopback only."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return dict(os.environ, PYTHONPATH=path, RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0")


def recorded_square(job: tuple[int, str, int]) -> int:
    """x * x; leaves ``attempt-<x>-<pid>`` (holding the node id) in the job's folder; the task ``hang`` sleeps on
    its first attempt, so that a test can kill its worker mid-task."""
    import ray
    x, folder, hang = job
    folder_path = Path(folder)
    first = not list(folder_path.glob(f"attempt-{x}-*"))
    (folder_path / f"attempt-{x}-{os.getpid()}").write_text(ray.get_runtime_context().get_node_id())
    if x == hang and first:
        time.sleep(120)
    time.sleep(0.3)  # long enough that the sweep spreads over every CPU
    return x * x


def kill_when_started(folder: Path, x: int, timeout_s: float = 60.0) -> threading.Thread:
    """A thread that SIGKILLs the worker process running task ``x`` as soon as it has started."""
    def kill() -> None:
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            started = list(folder.glob(f"attempt-{x}-*"))
            if started:
                os.kill(int(started[0].name.rsplit("-", 1)[1]), signal.SIGKILL)
                return
            time.sleep(0.05)
    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


def attempts(folder: Path, x: int) -> list[Path]:
    return sorted(folder.glob(f"attempt-{x}-*"))


def report_without_timing(path: Path) -> dict:
    report = json.loads(Path(path).read_text())
    report.pop("seconds", None)
    for candidate in report["candidates"]:
        candidate.pop("fit_seconds", None)  # wall-clock times: the only fields a backend may change
    return report


PLUGIN = '''
from triplanar.effects import EndFriction, register


@register
class PluginTip(EndFriction):
    """End friction under another name: an effect only a plugin defines."""

    name = "plugin_tip"
'''


def ray_daemons(session: str | None = None) -> set[int]:
    """Process ids of Ray's node daemons (raylet, gcs_server) on this machine; with ``session``, those of that Ray
    instance only (its session name is on each of its daemons' command lines)."""
    import subprocess
    found = subprocess.run(["pgrep", "-x", "raylet|gcs_server"], capture_output=True, text=True).stdout
    pids = {int(pid) for pid in found.split()}
    return pids if session is None else {pid for pid in pids if session in _command_line(pid)}


def ray_session(address: str) -> str:
    """The session name of the Ray instance whose GCS listens at ``address`` (read from its raylets)."""
    import re
    for pid in ray_daemons():
        command = _command_line(pid)
        if f"--gcs-address={address}" in command:
            return re.search(r"--session-name=(\S+)", command).group(1)
    raise LookupError(f"no raylet of the Ray at {address}")


def _command_line(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
    except OSError:  # it has exited meanwhile
        return ""
