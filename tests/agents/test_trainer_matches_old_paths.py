"""The one trainer (agents.trainer) trains, from a shipped YAML and a seed, the very model the two trainers it replaced
did (agents.train_ppo for v0, agents.train_robust for v1): parameters, optimiser state and normalisation statistics
equal bit for bit after one rollout (4,096 steps), with the evaluations and checkpoints of each layout firing on
the way. Run before the old trainers were removed; kept in the history as the evidence."""

from __future__ import annotations

import hashlib
import pickle
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")


def model_digest(run_dir: Path) -> str:
    """sha256 over a finished run's policy parameters, optimiser state and VecNormalize statistics."""
    from stable_baselines3.common.save_util import load_from_zip_file
    _, params, _ = load_from_zip_file(str(Path(run_dir) / "final_model.zip"), device="cpu")
    digest = hashlib.sha256()
    for name in sorted(params):
        if name.endswith("optimizer"):
            for _, state in sorted(params[name]["state"].items()):
                for key in sorted(state):
                    digest.update(np.asarray(state[key]).tobytes())
        else:
            for key in sorted(params[name]):
                digest.update(key.encode())
                digest.update(params[name][key].numpy().tobytes())
    with open(Path(run_dir) / "vecnormalize.pkl", "rb") as f:
        stats = pickle.load(f)
    for array in (stats.obs_rms.mean, stats.obs_rms.var, stats.ret_rms.mean, stats.ret_rms.var):
        digest.update(np.asarray(array).tobytes())
    return digest.hexdigest()


@pytest.mark.long
@pytest.mark.parametrize("kind", ["v0", "v1-ppo", "v1-recurrent"])
def test_the_one_trainer_trains_the_old_trainers_model(kind, tmp_path) -> None:
    from agents.trainer import TrainTask, train_run
    if kind == "v0":
        from agents.train_ppo import DEFAULT_CONFIG, load_config, train_ppo
        overrides = {"train.eval_freq": 2048, "train.checkpoint_freq": 2048}   # both fire within the run
        old = train_ppo(load_config(DEFAULT_CONFIG, overrides), tmp_path / "old", seed=3, total_timesteps=4096)
        old_dir = old.run_dir
        new = train_run(TrainTask(str(tmp_path / "new"), 3, 4096, overrides=tuple(overrides.items()),
                                  env_id="TriPlanarShear-v0"))
    else:   # the default eval_freq evaluates at the start and at the end
        from agents.train_robust import RobustTask, train_robust
        algo = kind.split("-")[1]
        old_dir = train_robust(RobustTask(str(tmp_path / "old"), 3, 4096, algo=algo))["run_dir"]
        new = train_run(TrainTask(str(tmp_path / "new"), 3, 4096, algo=algo, env_id="TriPlanarShear-v1"))
    assert new["timesteps"] == 4096
    assert model_digest(new["run_dir"]) == model_digest(old_dir)
    curve = [line.split(",", 2)[::2] for line in (Path(new["run_dir"]) / "learning_curve.csv").read_text().splitlines()]
    old_curve = [line.split(",", 2)[::2] for line in (Path(old_dir) / "learning_curve.csv").read_text().splitlines()]
    assert curve == old_curve   # the evaluations too (all but the wall-clock column)
