"""Robust PPO training (agents.train_robust): the recurrent controller, and resuming a run from its checkpoint."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from agents import train_robust as tr
from agents.heldout import nominal_benches, run_episode


@pytest.mark.slow
def test_recurrent_run_resumes_from_its_checkpoint_and_plays_an_episode(tmp_path, monkeypatch):
    monkeypatch.setattr(tr, "CURVE_BENCHES", 1)
    monkeypatch.setattr(tr, "RECURRENT_KWARGS", dict(tr.RECURRENT_KWARGS, n_steps=64, batch_size=64, n_epochs=1))
    task = tr.RobustTask(str(tmp_path), 0, 512, (), 256, "recurrent", checkpoint_freq=256)

    class Stop(Exception):
        pass

    # Interrupt the run after its first checkpoint (as a kill would), then run the task again: it continues.
    real_save = tr._atomic
    saved: list[str] = []

    def save_then_stop(save, path):
        real_save(save, path)
        saved.append(path.name)
        if path.name == "state.json":
            raise Stop

    monkeypatch.setattr(tr, "_atomic", save_then_stop)
    with pytest.raises(Stop):
        tr.train_robust(task)
    monkeypatch.setattr(tr, "_atomic", real_save)
    state = json.loads((tmp_path / "seed_0" / "checkpoint" / "state.json").read_text())
    assert 256 <= state["timesteps"] < 512
    summary = tr.train_robust(task)
    assert summary["algo"] == "recurrent" and summary["timesteps"] >= 512
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
