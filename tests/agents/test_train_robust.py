"""Robust PPO training (agents.train_robust): the recurrent controller, and resuming a run from its checkpoint."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from agents import run_benches, train_robust as tr
from agents.heldout import nominal_benches, run_episode


@pytest.mark.slow
def test_recurrent_run_resumes_from_its_checkpoint_and_plays_an_episode(tmp_path, monkeypatch):
    monkeypatch.setattr(run_benches, "CURVE_BENCHES", 1)
    small = {"n_envs": 4, "hyperparams.n_steps": 64, "hyperparams.batch_size": 64, "hyperparams.n_epochs": 1,
             "env.start_bank": 4}
    task = tr.RobustTask(str(tmp_path), 0, 512, (), 256, "recurrent", checkpoint_freq=256,
                         overrides=tuple(sorted(small.items())))

    class Stop(Exception):
        pass

    # Interrupt the run after its first checkpoint (as a kill would), then run the task again: it continues.
    real_save = run_benches.write_atomic
    saved: list[str] = []

    def save_then_stop(path, save):
        real_save(path, save)
        saved.append(path.name)
        if path.name == "state.json":
            raise Stop

    monkeypatch.setattr(run_benches, "write_atomic", save_then_stop)
    with pytest.raises(Stop):
        tr.train_robust(task)
    monkeypatch.setattr(run_benches, "write_atomic", real_save)
    state = json.loads((tmp_path / "seed_0" / "checkpoint" / "state.json").read_text())
    assert 256 <= state["timesteps"] < 512
    summary = tr.train_robust(task)
    assert summary["algo"] == "recurrent" and summary["timesteps"] >= 512
    ran = tr.run_config(tmp_path / "seed_0")
    assert ran["hyperparams"]["n_steps"] == 64 and ran["env"]["frame_stack"] == 1 and ran["env"]["randomize"]
    curve = (tmp_path / "seed_0" / "learning_curve.csv").read_text().splitlines()
    assert len(curve) >= 3   # the rows from before the interruption are kept

    policy = tr.load_policy(tmp_path / "seed_0", "recurrent")
    assert policy.name == "ppo_recurrent"
    outcome = run_episode(policy, nominal_benches((40.0,))[0], seed=0)
    assert outcome.controller == "ppo_recurrent" and outcome.steps > 0
    # the LSTM state is kept within an episode and cleared by reset
    policy.reset(40.0, None)
    assert policy.state is None and policy.episode_start.all()
    policy.act(np.zeros(15, dtype=np.float32))
    assert policy.state is not None and not policy.episode_start.any()


def test_config_errors_name_the_file_and_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("env:\n  latency_s: 0.003\n")
    with pytest.raises(ValueError, match="bad.yaml: env: latency_s"):
        tr.load_robust_config(bad)
    bad.write_text("hyperparms: {}\n")
    with pytest.raises(ValueError, match="unknown key 'hyperparms'"):
        tr.load_robust_config(bad)
    bad.write_text("train:\n  total_timesteps: -5\n")
    with pytest.raises(ValueError, match="train.total_timesteps"):
        tr.load_robust_config(bad)
    with pytest.raises(ValueError, match="algo is 'ppo'"):
        tr.RobustTask(str(tmp_path), 0, algo="recurrent", config=str(tr.ROBUST_CONFIG)).resolved()
    with pytest.raises(ValueError, match="cannot read"):
        tr.load_robust_config(tmp_path / "missing.yaml")


def test_shipped_configs_load_and_build_their_env():
    paths = sorted(p for p in tr.ROBUST_CONFIG.parent.glob("*.yaml") if p.name != "ppo.yaml")  # ppo.yaml: v0's
    assert tr.ROBUST_CONFIG in paths and tr.RECURRENT_CONFIG in paths
    for path in paths:
        config = tr.load_robust_config(path)
        venv = tr.make_vec_env(config, seed=0)
        frames = tr.frame_stack_of(config)
        assert venv.num_envs == config["n_envs"] and venv.observation_space.shape == (15 * frames,)
