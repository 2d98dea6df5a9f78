"""Layering: triplanar -> envs -> agents -> experiments, and triplanar -> workbench -> commands.

Each check runs in a fresh interpreter and looks at ``sys.modules``: the physics and workbench must work for a lab
user who installed the package without the ``rl`` extra (no torch, no stable-baselines3).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RL = ("torch", "stable_baselines3", "tensorboard")


def _loaded_after(code: str) -> set[str]:
    """Top-level package names in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    script = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                         check=True).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


def _top(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


@pytest.mark.parametrize("code", [
    "import triplanar",
    "import triplanar.workbench, triplanar.paper, triplanar.labdata",
    "import triplanar.cli; triplanar.cli.build_parser()",
])
def test_the_core_imports_neither_gymnasium_nor_the_rl_stack(code: str) -> None:
    loaded = _top(_loaded_after(code))
    assert not loaded & {*RL, "gymnasium", "envs", "agents", "experiments"}


def test_envs_and_make_vec_need_no_rl_stack() -> None:
    loaded = _loaded_after("import gymnasium as gym, envs\n"
                           "gym.make_vec('TriPlanarShear-v0', num_envs=2).close()")
    assert "envs.vector" in loaded
    assert not _top(loaded) & {*RL, "agents", "experiments"}


def test_the_workbench_does_not_import_the_commands() -> None:
    loaded = _loaded_after("import triplanar.workbench.cli_common")
    assert "triplanar.commands" not in loaded


def test_a_command_needing_a_missing_extra_says_how_to_install_it(monkeypatch, capsys) -> None:
    from triplanar import cli, commands
    monkeypatch.setattr(commands, "RL_MODULES", ("no_such_module_for_this_test",))
    assert cli.main(["train", "--timesteps", "1", "--out", "unused"]) == 2
    err = capsys.readouterr().err
    assert "no_such_module_for_this_test not installed" in err and "triplanar-shear[rl]" in err
