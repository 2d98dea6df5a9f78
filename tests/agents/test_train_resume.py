"""An interrupted ``train`` resumes to the same complete result; train and study refuse what they cannot do and
name the bad setting."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest
import yaml

from agents.train_ppo import DEFAULT_CONFIG, load_config, train_ppo

ROOT = Path(__file__).resolve().parents[2]


def tiny_config() -> dict:
    config = load_config(DEFAULT_CONFIG, {"n_envs": 4, "ppo.n_steps": 128, "ppo.batch_size": 128, "ppo.n_epochs": 2,
                                          "train.eval_freq": 1024, "train.checkpoint_freq": 1024})
    config["eval_loads"] = [27.8, 55.6]
    return config


def refused(capsys, *args: str) -> str:
    """Run the command line in this process (an interpreter of its own costs 3 s of CPU to import the stack) and
    return its stderr; it must refuse with exit code 2, naming the problem, without a traceback (an exception other
    than a named error would fail the test here)."""
    from triplanar.cli import main
    try:
        code = main(list(args))
    except SystemExit as refusal:  # argparse's
        code = refusal.code
    err = capsys.readouterr().err
    assert code == 2, err
    return err


def cli(*args: str, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "triplanar.cli", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def curve_steps(path: Path) -> list[int]:
    with open(path) as f:
        return [int(r["timesteps"]) for r in csv.DictReader(f)]


def test_train_killed_and_rerun_finishes_without_touching_its_checkpoints(tmp_path) -> None:
    config = tmp_path / "ppo.yaml"
    config.write_text(yaml.safe_dump(tiny_config()))
    args = ("train", "--config", str(config), "--out", str(tmp_path / "runs"), "--timesteps", "2048")
    run = tmp_path / "runs" / "seed_0"
    first = cli(*args)
    deadline = time.time() + 900
    while not (run / "checkpoints" / "ppo_vecnormalize_1024_steps.npz").exists():
        assert first.poll() is None, first.communicate()
        assert time.time() < deadline
        time.sleep(0.2)
    first.send_signal(signal.SIGTERM)
    first.wait(60)
    assert not (run / "done.json").exists() and not (run / "final_model.zip").exists()
    saved = {p.name: p.read_bytes() for p in (run / "checkpoints").iterdir()}
    from triplanar.cli import main
    assert main(list(args)) == 0    # the rerun in this process (the first had to be one of its own, to be killed)
    assert json.loads((run / "done.json").read_text())["timesteps"] == 2048
    assert (run / "final_model.zip").exists() and (run / "vecnormalize.pkl").exists()
    for name, data in saved.items():  # the checkpoints the first run wrote are as they were
        assert (run / "checkpoints" / name).read_bytes() == data, name
    assert not list(run.rglob(".*partial*"))
    steps = curve_steps(run / "learning_curve.csv")
    assert steps == sorted(set(steps)) and steps[-1] == 2048  # no duplicate row after kill and resume
    # the study without training (`study --skip-train`, whose flag the tests below run) uses the finished run; at two
    # loads, not the study's twelve: the twelve cost 40 s of CPU and read the run no differently
    from experiments.study import run_study
    study = run_study(tmp_path / "study", ppo_dir=tmp_path / "runs", seeds=(0,), config=config, train=False,
                      loads=(27.8, 55.6), log=lambda _: None)
    assert [r.timesteps for r in study.ppo_runs] == [2048] and study.ppo_runs[0].model_path == run / "final_model.zip"
    assert (tmp_path / "study" / "summary.json").exists()


def test_resume_falls_back_past_a_truncated_checkpoint(tmp_path, capsys) -> None:
    config = tiny_config()
    train_ppo(config, tmp_path, seed=0, total_timesteps=2048)
    run = tmp_path / "seed_0"
    for name in ("done.json", "final_model.zip", "vecnormalize.pkl"):
        (run / name).unlink()
    newest = run / "checkpoints" / "ppo_2048_steps.zip"
    newest.write_bytes(newest.read_bytes()[:1000])  # torn write
    with pytest.raises(zipfile.BadZipFile):
        zipfile.ZipFile(newest)
    resumed = train_ppo(config, tmp_path, seed=0, total_timesteps=3072)
    assert resumed.timesteps == 3072 and resumed.model_path == run / "final_model.zip"
    assert "ppo_2048_steps.zip does not load" in capsys.readouterr().err
    assert curve_steps(resumed.curve_path) == [1024, 2048, 3072]


@pytest.mark.parametrize("value", ["0", "-5", "x"])
def test_train_refuses_non_positive_timesteps(tmp_path, capsys, value) -> None:
    assert "--timesteps" in refused(capsys, "train", "--out", str(tmp_path), "--timesteps", value)
    assert not list(tmp_path.rglob("done.json"))


@pytest.mark.parametrize("text, message", [
    ("n_envs: 4\ntypo_key: 1\n", "unknown key 'typo_key'"),
    ("train: {total_timestep: 5}\n", "unknown key train.total_timestep"),
    ("n_envs: [4\n", "invalid YAML"),
    ("eval_loads: []\n", "eval_loads"),
    ("env: {no_such_field: 1}\n", "env:"),
])
def test_train_config_errors_are_named(tmp_path, capsys, text, message) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    err = refused(capsys, "train", "--config", str(config), "--out", str(tmp_path / "runs"), "--timesteps", "128")
    assert message in err and str(config) in err, err


def test_study_refuses_eval_loads_without_the_plot_load_before_training(tmp_path, capsys) -> None:
    config = tmp_path / "ppo.yaml"
    data = tiny_config()
    data["eval_loads"] = [55.6]
    config.write_text(yaml.safe_dump(data))
    assert "eval_loads must include 27.8 N" in refused(capsys, "study", "--out", str(tmp_path / "out"), "--ppo-dir",
                                                        str(tmp_path / "runs"), "--config", str(config), "--seeds",
                                                        "0", "--timesteps", "1024")
    assert not (tmp_path / "runs").exists()


def test_study_writes_no_doc_unless_asked_and_never_over_a_file(tmp_path, capsys) -> None:
    from triplanar.commands.study import add_arguments
    import argparse
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert parser.parse_args(["--out", "x"]).doc is None
    doc = tmp_path / "report.md"
    doc.write_text("mine")
    assert "file exists" in refused(capsys, "study", "--out", str(tmp_path / "out"), "--ppo-dir", str(tmp_path / "runs"),
                                    "--seeds", "0", "--skip-train", "--doc", str(doc))
    assert doc.read_text() == "mine"


def test_study_skip_train_without_a_finished_run_is_a_named_error(tmp_path, capsys) -> None:
    assert "not a finished run" in refused(capsys, "study", "--out", str(tmp_path / "out"), "--ppo-dir",
                                           str(tmp_path / "runs"), "--seeds", "0", "--skip-train")


def test_no_resume_removes_the_previous_runs_checkpoints(tmp_path) -> None:
    config = tiny_config()
    train_ppo(config, tmp_path, seed=0, total_timesteps=2048)
    run = tmp_path / "seed_0"
    assert (run / "checkpoints" / "ppo_2048_steps.zip").exists()
    again = train_ppo(config, tmp_path, seed=0, total_timesteps=1024, resume=False)
    assert again.timesteps == 1024
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["ppo_1024_steps.zip",
                                                                      "ppo_vecnormalize_1024_steps.npz"]


def test_study_refuses_a_budget_below_one_evaluation_before_training(tmp_path) -> None:
    from experiments.study import run_study
    with pytest.raises(ValueError, match="eval_freq"):
        run_study(tmp_path / "out", ppo_dir=tmp_path / "runs", seeds=(0,), timesteps=2048, log=lambda s: None)
    assert not (tmp_path / "runs").exists()
