"""``import triplanar`` registers every id, so ``gym.make("triplanar:...")`` works from any folder: an empty one, and
one holding a user's own package named ``envs`` (the project's env package's name), which stays the user's."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

MAKE = """
import json, sys
import gymnasium as gym
env = gym.make("triplanar:TriPlanarShear-v1")
realistic = gym.make("TriPlanarShearRealistic-v0")
print(json.dumps({"module": type(env.unwrapped).__module__, "same": type(env.unwrapped) is type(realistic.unwrapped),
                  "max_steps": env.spec.max_episode_steps, "threshold": env.spec.reward_threshold}))
"""


def _run(code: str, cwd: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_make_from_an_empty_folder(tmp_path: Path) -> None:
    out = _run(MAKE, tmp_path)
    assert out == {"module": "envs.triplanar_shear_v1", "same": True, "max_steps": 399, "threshold": -1.0}


def test_make_beside_a_users_own_envs_package(tmp_path: Path) -> None:
    (tmp_path / "envs").mkdir()
    (tmp_path / "envs" / "__init__.py").write_text("OWNER = 'user'\n")
    out = _run(MAKE.replace('"module"', '"owner": __import__("envs").OWNER, "module"'), tmp_path)
    # the project's env under its private name; the name envs stays the user's package
    assert out == {"owner": "user", "module": "_triplanar_envs.triplanar_shear_v1", "same": True, "max_steps": 399,
                   "threshold": -1.0}


def test_import_triplanar_before_gymnasium_registers_without_loading_it(tmp_path: Path) -> None:
    out = _run("import json, sys, triplanar\nloaded = 'gymnasium' in sys.modules\nimport gymnasium as gym\n"
               "print(json.dumps({'loaded': loaded, 'ids': sorted(i for i in gym.registry if 'TriPlanar' in i)}))",
               tmp_path)
    assert out == {"loaded": False, "ids": ["TriPlanarShear-v0", "TriPlanarShear-v1", "TriPlanarShearIdeal-v0",
                                            "TriPlanarShearRealistic-v0"]}
