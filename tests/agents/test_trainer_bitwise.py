"""The trainer's evaluations, checkpoints and run folder leave the training itself untouched: a run of
agents.trainer is, parameter for parameter, the plain SB3 run its YAML describes (the same batched env, VecNormalize
and algorithm, seeded alike, no callbacks), on v0 and v1, PPO and recurrent PPO, with evaluations and checkpoints
firing during the run. (That the trainer trains what the two trainers it replaced trained, for the shipped YAMLs at
4,096 steps: tests/agents/test_trainer_matches_old_paths.py, run before they were removed.)"""

from __future__ import annotations

import pytest
import torch

pytest.importorskip("sb3_contrib")

from agents import run_benches
from agents.train_config import V0, V1, algo_class, hyperparams_of, make_vec_env, policy_of
from agents.trainer import TrainTask, train_run

STEPS = 256


def tiny(env_id: str) -> dict:
    section = "ppo" if env_id == V0 else "hyperparams"
    small = {"n_envs": 2, f"{section}.n_steps": 64, f"{section}.batch_size": 64, f"{section}.n_epochs": 1,
             "train.eval_freq": 128, "train.checkpoint_freq": 128}
    return {**small, "eval_loads": [40.0]} if env_id == V0 else {**small, "env.start_bank": 4}


@pytest.mark.slow
@pytest.mark.parametrize("env_id, algo", [(V0, "ppo"), (V1, "ppo"), (V1, "recurrent")])
def test_a_trained_run_is_the_plain_sb3_run_of_its_yaml(env_id, algo, tmp_path, monkeypatch) -> None:
    from stable_baselines3.common.save_util import load_from_zip_file
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize
    monkeypatch.setattr(run_benches, "CURVE_BENCHES", 1)
    task = TrainTask(str(tmp_path), 2, STEPS, algo=algo, overrides=tuple(tiny(env_id).items()), env_id=env_id)
    summary = train_run(task)
    run_dir = tmp_path / "seed_2"
    checkpoints = list((run_dir / ("checkpoints" if env_id == V0 else "checkpoint")).glob("*.zip"))
    assert summary["timesteps"] == STEPS and checkpoints   # a checkpoint was written during the run
    assert len((run_dir / "learning_curve.csv").read_text().splitlines()) >= 3   # evaluations ran during it
    config = task.resolved()
    venv = VecNormalize(VecMonitor(make_vec_env(config, 2)), **(config.get("normalize") or {}))
    plain = algo_class(algo)(policy_of(config), venv, seed=2, device="cpu", **hyperparams_of(config))
    plain.learn(STEPS)
    _, trained, _ = load_from_zip_file(str(run_dir / "final_model.zip"), device="cpu")
    reference = plain.policy.state_dict()
    assert set(trained["policy"]) == set(reference)
    for name, tensor in reference.items():
        assert torch.equal(trained["policy"][name], tensor), name
