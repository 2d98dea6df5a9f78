"""The executor flags are on every sweeping command, and Ray stays optional: nothing imports it until asked."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

CHECK = """
import sys
from triplanar.cli import build_parser
parser = build_parser()
sub = next(a for a in parser._actions if a.dest == "command").choices
for name in ("diagnose", "fit", "paper", "lab-data", "train", "study"):
    options = {o for a in sub[name]._actions for o in a.option_strings}
    assert {"--executor", "--ray-address"} <= options, name
    executor = next(a for a in sub[name]._actions if "--executor" in a.option_strings)
    assert executor.choices == ["local", "serial", "ray"] and executor.default == "local", name
import triplanar.executor, triplanar.workbench.executor, triplanar.paper, triplanar.labdata
assert "ray" not in sys.modules, "ray imported without --executor ray"
print("ok")
"""


@pytest.mark.slow  # a fresh interpreter imports the CLI and every command
def test_every_sweeping_command_has_the_executor_flags_and_ray_is_not_imported() -> None:
    done = subprocess.run([sys.executable, "-c", CHECK], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_the_workbench_executor_names_are_the_core_ones() -> None:
    import triplanar.executor as core
    import triplanar.workbench.executor as workbench
    for name in ("run_tasks", "executor_scope", "ExecutorLike", "SerialExecutor", "TaskCheckpoint", "pool_scope"):
        assert getattr(workbench, name) is getattr(core, name)


def test_an_unknown_backend_is_named(tmp_path) -> None:
    from triplanar.executor import run_tasks
    with pytest.raises(ValueError, match="'dask'"):
        run_tasks(abs, [1], "dask")
