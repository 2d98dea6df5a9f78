"""numba's cache: found where numba puts it (also for a read-only install), kept honest, and a cold one announced."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from triplanar.compiled_cache import NOTICE, drop_if_stale

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str, *, cwd: Path = ROOT, pythonpath: Path = ROOT, **env: str) -> subprocess.CompletedProcess:
    base = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
    base.update(PYTHONPATH=str(pythonpath), **env)
    out = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=base, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out


# Two small compiled functions of the kernel: compiling them takes a second or two.
_COMPILE_TWO = ("import numpy as np; from triplanar import kernel as K; ws = K.new_workspace(); "
                "K.quat_to_matrix(np.array([1.0, 0, 0, 0]), np.empty((3, 3)))")


def test_a_cold_cache_is_announced_once_and_a_warm_one_not(tmp_path) -> None:
    cold = _run(_COMPILE_TWO, NUMBA_CACHE_DIR=str(tmp_path))
    assert cold.stderr.count(NOTICE) == 1
    assert any(tmp_path.rglob("kernel.new_workspace-*.nbi")) and any(tmp_path.rglob("kernel.quat_to_matrix-*.nbi"))
    warm = _run(_COMPILE_TWO, NUMBA_CACHE_DIR=str(tmp_path))
    assert NOTICE not in warm.stderr


def test_numba_cache_dir_follows_numba_cache_dir_env(tmp_path) -> None:
    out = _run("from triplanar.compiled_cache import numba_cache_dir; import triplanar.stepping as S; "
               "print(numba_cache_dir(S.__file__))", NUMBA_CACHE_DIR=str(tmp_path))
    where = Path(out.stdout.strip())
    assert where.parent == tmp_path and where.name.startswith("triplanar_")
    assert (where / "stepping.kernel.sha256").exists()  # the stale-cache check keeps its stamp there


def _read_only_copy(tmp_path: Path) -> Path:
    """The package as a read-only install would have it. (Tests may run as root, for whom nothing is read-only: a
    file named ``__pycache__`` makes the directory unusable for caches just the same.)"""
    site = tmp_path / "site"
    shutil.copytree(ROOT / "triplanar", site / "triplanar", ignore=shutil.ignore_patterns("__pycache__"))
    for package in site.rglob("__init__.py"):
        (package.parent / "__pycache__").write_text("not a directory")
    return site


def test_a_read_only_install_caches_in_the_user_cache_and_drops_stale_code_there(tmp_path) -> None:
    site, xdg = _read_only_copy(tmp_path), tmp_path / "xdg"
    code = ("import triplanar.stepping, triplanar.compiled_cache as C; print(C.numba_cache_dir(triplanar.stepping.__file__)); "
            + _COMPILE_TWO)
    out = _run(code, cwd=tmp_path, pythonpath=site, XDG_CACHE_HOME=str(xdg))
    where = Path(out.stdout.strip().splitlines()[0])
    assert where.parent == xdg / "numba" and where.name.startswith("triplanar_")
    assert any(where.glob("kernel.new_workspace-*.nbi"))      # numba fell back there by itself
    assert (where / "stepping.kernel.sha256").exists()       # and the stale-cache check followed it
    (where / "stepping.integrate_ws-1.py311.nbi").write_text("compiled with the old kernel")
    kernel = site / "triplanar" / "kernel.py"
    kernel.write_text(kernel.read_text() + "\n# changed\n")  # (an upgrade in place)
    _run("import triplanar.stepping", cwd=tmp_path, pythonpath=site, XDG_CACHE_HOME=str(xdg))
    assert not (where / "stepping.integrate_ws-1.py311.nbi").exists()


def test_drop_if_stale_does_nothing_without_a_cache(tmp_path) -> None:
    source = tmp_path / "kernel.py"
    source.write_text("x = 1\n")
    assert not drop_if_stale(None, "*.nbi", [source], "kernel.sha256")


@pytest.mark.slow
@pytest.mark.long
def test_after_the_warmup_nothing_compiles(tmp_path) -> None:
    """``make install`` runs the warm-up: then the first trace, env step, vector-env step and model-based control
    decision (the prediction from a copied bench state) compile nothing. Long (`make test-slow`): the warm-up compiles
    every kernel into an empty cache (a minute or two of CPU), and only an empty cache shows a kernel the warm-up misses
    (in a warm one, any earlier run may have compiled it)."""
    warm = _run("import sys; from triplanar.warmup import main; sys.exit(main())", NUMBA_CACHE_DIR=str(tmp_path))
    assert "is out of date" not in warm.stderr  # the warm-up makes TriPlanarShear-v0 on purpose: no notice
    code = ("import numpy as np, gymnasium as gym, envs; from triplanar import Effect, paper_model, simulate; "
            "simulate(paper_model('B', 40.0)); e = gym.make('TriPlanarShear-v0'); e.reset(seed=1); "
            "e.step(np.ones(2, np.float32)); v = gym.make_vec('TriPlanarShear-v0', num_envs=3); v.reset(seed=2); "
            "v.step(np.ones((3, 2), np.float32))\n"
            "from agents.mpc import MPCController; e1 = gym.make('TriPlanarShear-v1'); o, _ = e1.reset(seed=3)\n"
            "c = MPCController(bank_size=4, hypotheses=2, samples=4, elites=2, start_periods=0)\n"
            "c.reset(e1.unwrapped.episode_bench.load_N, "
            "e1.unwrapped.config)\n"
            "for _ in range(3): o = e1.step(c.act(o))[0]\n"
            "class Drag(Effect):\n    name, parameters = 'drag', {}\n"
            "    def wrench(self, t, state): return -2.0 * state.velocity, np.zeros(3)\n"
            "simulate(paper_model('A', 40.0, effects=[Drag()]))  # a user force: an object-mode block, not cached")
    out = _run(code, NUMBA_CACHE_DIR=str(tmp_path))
    assert NOTICE not in out.stderr
