"""Errors that name the right thing, and input that was quietly accepted."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from triplanar.atomic import MARK, temporary_path
from triplanar.cli import main
from triplanar.effects import REGISTRY, Effect, EffectError, make_effect
from triplanar.labdata import generate_lab_data, write_lab_data
from triplanar.measurement import MeasurementError

ROOT = Path(__file__).resolve().parents[3]


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_simulate_held_block_writes_the_plot_and_names_why_no_csv(tmp_path, capsys) -> None:
    csv, png = tmp_path / "f.csv", tmp_path / "f.png"
    code, out, err = run(capsys, "simulate", "--force", "3", "--out", csv, "--plot", png)
    assert code == 2 and png.stat().st_size > 0 and not csv.exists()
    assert f"--out {csv}: not written: the block held" in err and "1 sample" in err


@pytest.mark.parametrize("option", ["--out", "--plot"])
def test_simulate_refuses_an_empty_file_name(capsys, option) -> None:
    code, out, err = run(capsys, "simulate", "--force", "30", option, "")
    assert code == 2 and f"{option}: empty file name" in err


def test_lab_data_into_a_missing_folder_writes_there(tmp_path, capsys) -> None:
    target = tmp_path / "new" / "sub" / "lab.csv"
    code, out, err = run(capsys, "lab-data", "--out", target, "--loads", "40", "--repeats", "1")
    assert code == 0, err
    assert target.exists() and Path(f"{target}.truth.json").exists()
    assert sorted(p.name for p in target.parent.iterdir()) == ["lab.csv", "lab.csv.truth.json"]  # no temporary


def test_no_tests_to_write_names_the_users_file(tmp_path) -> None:
    path = tmp_path / "lab.csv"
    with pytest.raises(MeasurementError) as err:
        write_lab_data(path, [], {})
    assert err.value.path == str(path) and MARK not in str(err.value)
    tests, truth = generate_lab_data(loads=(40.0,), repeats=1, seed=1)
    with pytest.raises(MeasurementError) as err:  # a refusal from the writer names the user's file too
        write_lab_data(path, tests + tests, truth)
    assert err.value.path == str(path) and MARK not in str(err.value)
    assert not list(tmp_path.iterdir())


def test_write_measurements_into_a_missing_folder_names_the_file(tmp_path) -> None:
    from triplanar.measurement import write_measurements
    tests, _ = generate_lab_data(loads=(40.0,), repeats=1, seed=1)
    target = tmp_path / "missing" / "x.csv"
    with pytest.raises(MeasurementError, match="does not exist") as err:
        write_measurements(target, tests)
    assert err.value.path == str(target)


SLOW_WRITE = """
import sys, time
import triplanar.labdata as L
from triplanar.atomic import MARK, temporary_path
from triplanar.cli import main
real = L.write_measurements
def slow(path, tests):
    real(path, tests)
    print("written", flush=True)
    time.sleep(60)  # killed here: the temporary CSV exists
L.write_measurements = slow
sys.exit(main(["lab-data", "--out", sys.argv[1], "--loads", "40", "--repeats", "1"]))
"""


def test_sigterm_while_lab_data_writes_leaves_no_temporary_file(tmp_path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    target = tmp_path / "lab.csv"
    proc = subprocess.Popen([sys.executable, "-c", SLOW_WRITE, str(target)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "written", proc.stderr.read()
    assert [p for p in tmp_path.iterdir() if MARK in p.name]  # the temporary file is there
    proc.send_signal(signal.SIGTERM)
    proc.wait(60)
    assert proc.returncode == 128 + signal.SIGTERM
    assert not list(tmp_path.iterdir())  # neither the temporary files nor a half result
    assert "Traceback" not in proc.stderr.read()


# -- effects ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("spec, message", [
    ("end_friction:phi_deg=8,phi_deg=9", "phi_deg given twice"),
    ("end_friction:=8", "expected PARAM=VALUE"),
    ("end_friction:phi_deg=\u0668", "is not a number"),
    ("end_friction:phi_deg=1_0", "is not a number"),
])
def test_bad_effect_specifications(spec, message) -> None:
    with pytest.raises(EffectError, match=message):
        make_effect(spec)


def test_repeated_effect_and_candidates_are_refused(tmp_path, capsys) -> None:
    code, out, err = run(capsys, "simulate", "--force", "30", "--effect", "end_friction:phi_deg=8",
                         "--effect", "end_friction:phi_deg=9")
    assert code == 2 and "--effect end_friction given 2 times" in err
    from triplanar.workbench.candidates import resolve
    with pytest.raises(ValueError, match="given twice"):
        resolve(["tip_offset", "tip_offset"])
    tests, _ = generate_lab_data(loads=(30.0, 40.0), repeats=1, seed=1)
    from triplanar.measurement import write_measurements
    write_measurements(tmp_path / "d.csv", tests)
    code, out, err = run(capsys, "diagnose", tmp_path / "d.csv", "--candidates", "tip_offset,tip_offset",
                         "--out", tmp_path / "o")
    assert code == 2 and "tip_offset given twice" in err


names = st.sampled_from(sorted(REGISTRY) + ["nope", ""])
params = st.sampled_from(sorted({k for cls in REGISTRY.values() for k in cls.parameters}) + ["x", ""])
numbers = st.one_of(st.floats().map(repr), st.integers().map(str), st.text(max_size=4),
                    st.sampled_from(["nan", "inf", "-inf", "1e400", "\u0663", "\uff11", " 1 ", "1_0"]))


@st.composite
def specs(draw):
    items = draw(st.lists(st.tuples(params, st.sampled_from(["=", ":", "", "=="]), numbers), max_size=4))
    body = ",".join(f"{k}{sep}{v}" for k, sep, v in items)
    return draw(names) + draw(st.sampled_from([":", "", "::", ": "])) + body


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))  # inputs: the profile (tests/conftest.py)
@given(spec=st.one_of(specs(), st.text(max_size=40)))
def test_fuzz_effect_specifications_give_a_named_error_or_an_effect(spec) -> None:
    try:
        effect = make_effect(spec)
    except EffectError as err:
        assert str(err)
        return
    assert isinstance(effect, Effect) and effect.name in spec
    assert make_effect(repr(effect)) == effect  # what it prints reads back


def test_a_killed_writers_leftover_is_removed_by_the_next_write(tmp_path, capsys) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    target = tmp_path / "lab.csv"
    stale = [temporary_path(target, pid=dead.pid), temporary_path(f"{target}.truth.json", pid=dead.pid)]
    live = temporary_path(target)  # a writer still running: left alone
    for p in stale + [live]:
        p.write_text("partial")
    code, out, err = run(capsys, "lab-data", "--out", target, "--loads", "40", "--repeats", "1")
    assert code == 0, err
    assert not any(p.exists() for p in stale) and live.exists()
