"""``triplanar train`` on TriPlanarShear-v1: bad input refused with the option named; a killed run continues."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from triplanar import cli

ROOT = Path(__file__).resolve().parents[3]
TINY = ["--set", "n_envs=2", "--set", "hyperparams.n_steps=64", "--set", "hyperparams.batch_size=64",
        "--set", "hyperparams.n_epochs=1", "--set", "train.checkpoint_freq=256", "--set", "train.eval_freq=100000",
        "--env-arg", "start_bank=4"]


@pytest.mark.parametrize("args, message", [
    (["--algo", "recurrent"], "--algo is for --env TriPlanarShear-v1"),
    (["--env", "TriPlanarShear-v1", "--env-arg", "latency_s=0.003"], "latency_s must be a whole number"),
    (["--env", "TriPlanarShear-v1", "--env-arg", "lateny_s=0.01"], "unknown env argument(s) lateny_s"),
    (["--env", "TriPlanarShear-v1", "--set", "hyperparms.n_steps=8"], "unknown key 'hyperparms'"),
    (["--env", "TriPlanarShear-v1", "--algo", "recurrent", "--config", "agents/robust.yaml"], "algo is 'ppo'"),
    (["--config", "agents/robust.yaml"], "env_id is 'TriPlanarShear-v1'"),
    (["--env", "TriPlanarShear-v1", "--config", "agents/ppo.yaml"], "env_id is 'TriPlanarShear-v0'"),
])
def test_bad_input_is_refused_with_the_option_named(args, message, tmp_path, capsys) -> None:
    assert cli.main(["train", *args, "--out", str(tmp_path), "--executor", "serial", "--no-progress"]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.rglob("*.zip"))


@pytest.mark.slow
def test_a_killed_v1_run_continues_from_its_checkpoint(tmp_path, capsys) -> None:
    args = [sys.executable, "-m", "triplanar.cli", "train", "--env", "TriPlanarShear-v1", "--timesteps", "1024",
            "--seed", "5", "--out", str(tmp_path), "--executor", "serial", "--no-progress", *TINY]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    state = tmp_path / "seed_5" / "checkpoint" / "state.json"
    first = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 600
    while not state.exists():
        assert first.poll() is None, first.communicate()
        assert time.time() < deadline
        time.sleep(0.2)
    first.send_signal(signal.SIGTERM)
    first.wait(60)
    assert not (tmp_path / "seed_5" / "done.json").exists()
    resumed_from = json.loads(state.read_text())["timesteps"]
    assert 256 <= resumed_from < 1024
    assert cli.main(args[3:]) == 0      # the rerun in this process (the first had to be one of its own, to be killed)
    done = json.loads((tmp_path / "seed_5" / "done.json").read_text())
    assert done["timesteps"] >= 1024 and done["algo"] == "ppo"
    ran = json.loads((tmp_path / "seed_5" / "config.json").read_text())
    assert ran["n_envs"] == 2 and ran["env"]["start_bank"] == 4 and ran["env_id"] == "TriPlanarShear-v1"
    curve = (tmp_path / "seed_5" / "learning_curve.csv").read_text().splitlines()
    assert int(curve[1].split(",")[0]) < resumed_from   # the row from before the kill is kept
    # not silently mixed with the run (in this process: a third interpreter would cost 8 s of CPU to refuse)
    assert cli.main([*args[3:], "--set", "hyperparams.learning_rate=0.001"]) == 2
    assert "another hyperparams" in capsys.readouterr().err
