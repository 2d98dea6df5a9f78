"""The shipped YAMLs train, for a seed, the very model they trained when the two older trainers (agents.train_ppo
for v0, agents.train_robust for v1) were one (agents.trainer): policy parameters, optimiser state and normalisation
statistics after one rollout (4,096 steps, seed 3), against their sha256 recorded then, when the old and the new
path gave the same digests (commit cc52950's tests/agents/test_trainer_matches_old_paths.py; these digests
computed by this file's model_digest on the old trainers' runs).

The digests depend on the processor as well as on the code: 4,096 steps of training carry last-bit differences of
the float kernels (MKL's and NumPy's, each dispatched by the instruction set) into every parameter. They are kept per
machine class (:func:`machine_class`: the widest vector instructions and AMX). On a class with no record the test is
skipped, saying so; to record one, run this file's training at a commit whose training is known unchanged (one
whose test passed on a recorded class) and add the digests under the new class. That the trainer's callbacks leave
training untouched is checked on any machine by tests/agents/test_trainer_bitwise.py."""

from __future__ import annotations

import hashlib
import pickle
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

#: kind: (env id, algo, overrides, {machine class: sha256}). AVX2: recorded when the two trainers became one
#: (commit cc52950) and passed on the hosts of 2026-11-28/29 without AVX-512; AVX512+AMX: recorded 2026-11-29 at
#: 03fe23e (whose trainer is the one that passed on AVX2) on an Intel Xeon with AVX-512 and AMX.
RECORDED = {
    "v0": ("TriPlanarShear-v0", "ppo", {"train.eval_freq": 2048, "train.checkpoint_freq": 2048},
           {"AVX2": "f54f02b9c95d8b4afee35fad6e63c96202a3a3d2346ead1991eba67c97de30e7",
            "AVX512+AMX": "0ad53b6323d2a35ffb8666d5842e60f9f7617990a82a2ea2ddf302b1d8034a0a"}),
    "v1-ppo": ("TriPlanarShear-v1", "ppo", {},
               {"AVX2": "049ff43cfd69a2c40023561f9cd2a9d9cf03b3fa967278f065c055b36e0c09be",
                "AVX512+AMX": "4434262c41e38876e895afc8fdc934b3f4834784d1fcf131cd55f017107da9ed"}),
    "v1-recurrent": ("TriPlanarShear-v1", "recurrent", {},
                     {"AVX2": "e917d6f15052f50de5f3a6257215a2db6322c672e7f252255a1a1e64afeeb2d1",
                      "AVX512+AMX": "ebf173b2db396ac6dcc5c7355e867acab10174cc5a9dec19bea80a0ee54a2896"}),
}


def machine_class() -> str:
    """The processor's class as far as the float kernels' dispatch goes: torch's vector capability (``AVX2``,
    ``AVX512``, ...) and ``+AMX`` where the processor has AMX tiles (Linux's ``/proc/cpuinfo`` flags)."""
    import torch
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        flags = ""
    return torch.backends.cpu.get_cpu_capability() + ("+AMX" if "amx_tile" in flags else "")


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
    env_id, algo, overrides, by_class = RECORDED[kind]
    recorded = by_class.get(machine_class())
    if recorded is None:
        pytest.skip(f"no digest recorded for machine class {machine_class()!r} (recorded: {', '.join(by_class)}); "
                    "see the module docstring to record one")
    summary = train_run(TrainTask(str(tmp_path), 3, 4096, algo=algo, overrides=tuple(overrides.items()),
                                  env_id=env_id))
    assert summary["timesteps"] == 4096
    assert model_digest(summary["run_dir"]) == recorded
