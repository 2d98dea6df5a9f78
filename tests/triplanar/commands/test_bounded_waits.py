"""Bounded waits: a Ray address where nothing answers is refused within the stated timeout (loopback only), and
Ctrl-C ends a command quietly with status 130, its pool's workers stopped."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from triplanar import cli
from triplanar.ray_executor import CONNECT_TIMEOUT_S, check_answers

ROOT = Path(__file__).resolve().parents[3]


def test_a_ray_address_that_does_not_answer_is_refused() -> None:
    with pytest.raises(ValueError, match=f"--ray-address 127.0.0.1:1: nothing answers there within "
                                         f"{CONNECT_TIMEOUT_S:g} s"):
        check_answers("127.0.0.1:1")
    with pytest.raises(ValueError, match="expected HOST:PORT"):
        check_answers("127.0.0.1")


@pytest.mark.slow
def test_evaluate_on_a_ray_address_that_does_not_answer_exits_2(tmp_path, capsys) -> None:
    pytest.importorskip("ray")
    pytest.importorskip("stable_baselines3")
    assert cli.main(["evaluate", "--controller", "steel_tip", "--n", "1", "--out", str(tmp_path / "o"),
                     "--executor", "ray", "--ray-address", "127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert "nothing answers there" in err and "Traceback" not in err


def test_ctrl_c_exits_130_without_a_traceback(monkeypatch, capsys) -> None:
    from triplanar.commands import simulate

    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(simulate, "run", interrupted)
    assert cli.main(["simulate", "--force", "30"]) == 130
    err = capsys.readouterr().err
    assert err.strip() == "triplanar simulate: interrupted"


def _as_from_a_terminal() -> None:
    """The command as a terminal's foreground job starts it: SIGINT at its default. A shell without job control
    starts background jobs with SIGINT ignored, and a process started with it ignored keeps ignoring it (Python
    installs its Ctrl-C handler only over the default), so a test suite launched with `&` would otherwise test a
    Ctrl-C no terminal can send."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_ctrl_c_on_a_pool_stops_its_workers_quietly(tmp_path) -> None:
    pytest.importorskip("stable_baselines3")
    argv = [sys.executable, "-m", "triplanar.cli", "evaluate", "--controller", "steel_tip", "--n", "2000",
            "--seeds", "0", "1", "--out", str(tmp_path / "o"), "--executor", "local"]
    proc = subprocess.Popen(argv, cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_as_from_a_terminal)
    deadline = time.time() + 300
    while len(_children(proc.pid)) < 2:
        assert proc.poll() is None, proc.communicate()
        assert time.time() < deadline
        time.sleep(0.2)
    workers = _children(proc.pid)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)   # what Ctrl-C does: the whole foreground group
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert "interrupted" in err
    time.sleep(1.0)
    assert not [w for w in workers if _alive(w)]
    assert not (tmp_path / "o").exists()
