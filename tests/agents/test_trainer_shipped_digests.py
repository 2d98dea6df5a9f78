"""The shipped YAMLs train, for a seed, the very model they trained when the two older trainers (agents.train_ppo
for v0, agents.train_robust for v1) were one (agents.trainer): policy parameters, optimiser state and normalisation
statistics after one rollout (4,096 steps, seed 3), against their sha256 recorded then, when the old and the new
path gave the same digests (commit cc52950's tests/agents/test_trainer_matches_old_paths.py; these digests
computed by this file's model_digest on the old trainers' runs). The digests are this
machine's with the pinned torch; another CPU or torch build may differ in the last bits (then re-record them from a
commit whose training is known unchanged). That the trainer's callbacks leave training untouched is checked on any
machine by tests/agents/test_trainer_bitwise.py."""

from __future__ import annotations

import hashlib
import pickle
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

RECORDED = {  # kind: (env id, algo, overrides, sha256)
    "v0": ("TriPlanarShear-v0", "ppo", {"train.eval_freq": 2048, "train.checkpoint_freq": 2048},
           "f54f02b9c95d8b4afee35fad6e63c96202a3a3d2346ead1991eba67c97de30e7"),
    "v1-ppo": ("TriPlanarShear-v1", "ppo", {}, "049ff43cfd69a2c40023561f9cd2a9d9cf03b3fa967278f065c055b36e0c09be"),
    "v1-recurrent": ("TriPlanarShear-v1", "recurrent", {},
                     "e917d6f15052f50de5f3a6257215a2db6322c672e7f252255a1a1e64afeeb2d1"),
}


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
    with open(Path(run_dir) / "vecnormalize.pkl", "rb") as f:   # this test's own run
        stats = pickle.load(f)
    for array in (stats.obs_rms.mean, stats.obs_rms.var, stats.ret_rms.mean, stats.ret_rms.var):
        digest.update(np.asarray(array).tobytes())
    return digest.hexdigest()


@pytest.mark.long
@pytest.mark.parametrize("kind", sorted(RECORDED))
def test_a_shipped_yaml_trains_the_recorded_model(kind, tmp_path) -> None:
    from agents.trainer import TrainTask, train_run
    env_id, algo, overrides, recorded = RECORDED[kind]
    summary = train_run(TrainTask(str(tmp_path), 3, 4096, algo=algo, overrides=tuple(overrides.items()),
                                  env_id=env_id))
    assert summary["timesteps"] == 4096
    assert model_digest(summary["run_dir"]) == recorded
