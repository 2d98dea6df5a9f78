"""Commands that are safe to run: inputs never overwritten, options a command cannot honour refused (no claim of
what it did not do), workers die with their command, help and docs the user has, an interrupted diagnose resumes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from triplanar import write_measurements
from triplanar.cli import main
from triplanar.labdata import generate_lab_data

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    tests, _ = generate_lab_data(loads=(27.8, 40.0, 55.6), repeats=1, seed=5)
    path = tmp_path_factory.mktemp("wb") / "lab.csv"
    write_measurements(path, tests)
    return path


def run(capsys, *argv) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


@pytest.mark.parametrize("command", ["diagnose", "fit"])
def test_json_output_equal_to_the_data_is_refused(command, data, tmp_path, capsys) -> None:
    copy = tmp_path / "D.csv"
    copy.write_bytes(data.read_bytes())
    extra = ["--add", "end_friction"] if command == "fit" else []
    code, err = run(capsys, command, copy, "--json", copy, "--out", tmp_path / "o", *extra, "--workers", "1")
    assert code == 2 and "would be overwritten" in err and str(copy) in err
    assert copy.read_bytes() == data.read_bytes()


def test_json_output_through_a_link_is_refused(data, tmp_path, capsys) -> None:
    copy = tmp_path / "D.csv"
    copy.write_bytes(data.read_bytes())
    (tmp_path / "link.csv").symlink_to(copy)
    code, err = run(capsys, "diagnose", copy, "--json", tmp_path / "link.csv", "--out", tmp_path / "o")
    assert code == 2 and "would be overwritten" in err and copy.read_bytes() == data.read_bytes()


def test_compare_refuses_to_write_its_table_over_the_input(data, tmp_path, capsys) -> None:
    copy = tmp_path / "compare.csv"
    copy.write_bytes(data.read_bytes())
    code, err = run(capsys, "compare", copy, "--out", tmp_path)
    assert code == 2 and "--out" in err and "would be overwritten" in err
    assert copy.read_bytes() == data.read_bytes()


@pytest.mark.parametrize("folds", ["0", "1", "-5"])
def test_diagnose_refuses_fewer_than_two_folds(data, tmp_path, capsys, folds) -> None:
    code, err = run(capsys, "diagnose", data, "--folds", folds, "--out", tmp_path)
    assert code == 2 and f"--folds {folds}" in err and not (tmp_path / "diagnose.json").exists()


@pytest.mark.parametrize("n", ["0", "-1"])
def test_fit_forward_refuses_max_effects_below_one(data, tmp_path, capsys, n) -> None:
    code, err = run(capsys, "fit", data, "--forward", "--max-effects", n, "--out", tmp_path)
    assert code == 2 and f"--max-effects {n}" in err and not (tmp_path / "fit.json").exists()


def test_fit_refuses_an_effect_added_twice(data, tmp_path, capsys) -> None:
    code, err = run(capsys, "fit", data, "--add", "end_friction", "--add", "end_friction", "--out", tmp_path)
    assert code == 2 and "end_friction given twice" in err


def test_library_refuses_degenerate_folds_and_max_effects() -> None:
    from triplanar.workbench import Diagnoser, ForwardSelection
    for bad in (0, 1, -5):
        with pytest.raises(ValueError, match="folds"):
            Diagnoser(folds=bad)
    for bad in (0, -1):
        with pytest.raises(ValueError, match="max_effects"):
            ForwardSelection(max_effects=bad)


# -- workers die with their command ------------------------------------------------------------------

def children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            fields = stat.rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killing_diagnose_kills_its_pool_workers(data, tmp_path) -> None:
    """SIGTERM: the command terminates its pool on the way out, without a traceback. (SIGKILL, which the workers
    see through their parent-death signal: the resume test below kills diagnose so and checks its workers.)"""
    sig = signal.SIGTERM
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "triplanar.cli", "diagnose", str(data), "--out", str(tmp_path),
                             "--workers", "2", "--no-progress"], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 600
    workers: list[int] = []
    while len(workers) < 2:
        assert proc.poll() is None, proc.stderr.read()
        assert time.time() < deadline
        time.sleep(0.2)
        workers = children(proc.pid)
    time.sleep(1.0)
    proc.send_signal(sig)
    proc.wait(30)
    deadline = time.time() + 10
    while any(alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    left = [w for w in workers if alive(w)]
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left, f"workers {left} outlived their command"
    assert b"Traceback" not in proc.stderr.read()


# -- documentation the user has ---------------------------------------------------------------------------

def test_no_user_facing_text_points_outside_the_repository() -> None:
    offenders = []
    for path in ROOT.rglob("*"):
        if path.suffix in (".py", ".md", ".toml", ".yaml", ".txt") and ".git" not in path.parts \
                and ".venv" not in path.parts and "runs" not in path.parts:
            if "shared" + "/" in path.read_text(encoding="utf-8", errors="replace"):
                offenders.append(str(path.relative_to(ROOT)))
    offenders = [o for o in offenders if o != "tests/triplanar/commands/test_command_safety.py"]
    assert not offenders
    assert (ROOT / "docs" / "measurement-format.md").exists() and (ROOT / "docs" / "specimen-format.md").exists()


def test_help_points_to_the_format_docs_and_warns_about_pickles(capsys, monkeypatch) -> None:
    from triplanar.cli import build_parser
    monkeypatch.setenv("COLUMNS", "1000")  # no line wrapping (it breaks at hyphens)
    parser = build_parser()
    helps = {}
    for name in ("compare", "study"):
        with pytest.raises(SystemExit):
            parser.parse_args([name, "--help"])
        helps[name] = " ".join(capsys.readouterr().out.split())
    assert "docs/measurement-format.md" in helps["compare"] and "docs/specimen-format.md" in helps["compare"]
    assert "trusted source" in helps["study"] and "pickle" in helps["study"]
    readme = (ROOT / "README.md").read_text()
    assert "trusted source" in readme and "pickle" in readme


# -- a sweep: an interrupted diagnose resumes to the same complete result ----------------------------------

def diagnose_cmd(data: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "triplanar.cli", "diagnose", str(data), "--out", str(out), "--workers", "2",
            "--no-progress", "--no-plots", "--folds", "2", "--candidates",
            "end_friction,tip_offset,plane_tilt,rate_friction"]


def report_without_timing(path: Path) -> dict:
    import json
    report = json.loads(path.read_text())
    report.pop("seconds", None)
    for candidate in report["candidates"]:
        candidate.pop("fit_seconds", None)  # wall-clock times: the only thing a rerun may change
    return report


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_diagnose_killed_and_rerun_resumes_to_the_same_report(data, tmp_path, capsys) -> None:
    """Killed with SIGKILL while its pool works: the workers die with it, the finished tasks stay, and a rerun
    finishes to the report of a run never interrupted (the rerun and that run made in this process: the same
    command)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    assert main(diagnose_cmd(data, tmp_path / "whole")[3:]) == 0
    capsys.readouterr()
    assert not (tmp_path / "whole" / ".diagnose-partial").exists()  # removed when done
    out = tmp_path / "killed"
    partial = out / ".diagnose-partial"
    proc = subprocess.Popen(diagnose_cmd(data, out), cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.time() + 1200
    while not (partial.exists() and list(partial.glob("*.npz"))):
        assert proc.poll() is None and time.time() < deadline
        time.sleep(0.05)
    workers = children(proc.pid)
    assert len(workers) >= 2, workers           # --workers 2: the pool is at work
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    finished = {p.name: p.stat().st_mtime_ns for p in partial.glob("*.npz")}
    assert finished and not (out / "diagnose.json").exists()
    time.sleep(2 * 0.5 + 1)
    assert not [w for w in workers if alive(w)]
    assert main(diagnose_cmd(data, out)[3:]) == 0     # the rerun in this process (the killed run needed its own)
    assert report_without_timing(out / "diagnose.json") == report_without_timing(tmp_path / "whole" / "diagnose.json")
    assert not partial.exists()


def test_run_tasks_checkpoint_skips_finished_tasks_and_ignores_damaged_files(tmp_path) -> None:
    from triplanar.workbench.executor import TaskCheckpoint, run_tasks
    calls: list[int] = []

    def square(x: int) -> int:
        calls.append(x)
        return x * x

    checkpoint = TaskCheckpoint(tmp_path / "cp")
    assert run_tasks(square, [1, 2, 3], "serial", checkpoint=checkpoint) == [1, 4, 9] and calls == [1, 2, 3]
    damaged = tmp_path / "cp" / f"{checkpoint.key(square, 2)}.npz"
    damaged.write_bytes(b"\x80\x05trunc")
    calls.clear()
    assert run_tasks(square, [1, 2, 3, 4], "serial", checkpoint=checkpoint) == [1, 4, 9, 16]
    assert calls == [2, 4]
    checkpoint.clear()
    assert not (tmp_path / "cp").exists()


@pytest.mark.parametrize("argv", [
    ["simulate", "--force", "30", "--specimen", "{s}", "--out", "{s}"],
    ["simulate", "--force", "30", "--specimen", "{s}", "--plot", "{s}"],
    ["lab-data", "--specimen", "{s}", "--out", "{s}"],
    ["lab-data", "--specimen", "{s}", "--out", "{d}/x.csv", "--truth", "{s}"],
])
def test_simulate_and_lab_data_refuse_to_write_over_the_specimen(tmp_path, capsys, argv) -> None:
    from triplanar.specimen import reference, to_toml
    spec = tmp_path / "s.toml"
    spec.write_text(to_toml(*reference()))
    before = spec.read_bytes()
    code, err = run(capsys, *[a.format(s=spec, d=tmp_path) for a in argv])
    assert code == 2 and "would be overwritten" in err and spec.read_bytes() == before


POOL_SCRIPT = """
import os, sys, time
from triplanar.workbench.executor import pool_scope
with pool_scope(2) as pool:
    futures = [pool.submit(time.sleep, 120) for _ in range(2)]
    time.sleep(1.0)
    print(" ".join(str(p) for p in pool._processes), flush=True)
    futures[0].result()
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_pool_workers_die_with_their_owner(sig) -> None:
    """The pool of paper's figure drawing and of every workbench sweep (pool_scope)."""
    import importlib
    from triplanar.workbench.executor import pool_scope
    assert importlib.import_module("triplanar.paper.reproduce").pool_scope is pool_scope
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", POOL_SCRIPT], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    workers = [int(p) for p in proc.stdout.readline().split()]
    assert len(workers) == 2 and all(alive(w) for w in workers)
    proc.send_signal(sig)
    proc.wait(30)
    deadline = time.time() + 5
    while any(alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    left = [w for w in workers if alive(w)]
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left
    if sig == signal.SIGTERM:
        assert proc.returncode == 128 + signal.SIGTERM and "Traceback" not in proc.stderr.read()
