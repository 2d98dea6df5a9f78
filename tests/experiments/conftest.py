"""Fixtures of the label-generation tests (``experiments.distill_labels``): a scripted stand-in for the expert (the
point of those tests is the bookkeeping, not ``mpc``), and a label folder's shards read back."""

from __future__ import annotations

import numpy as np
import pytest

CPU_TIMES = ("expert_cpu_s", "episode_cpu_s")  # CPU times: the only content of a shard that differs between runs


@pytest.fixture
def fast_expert(monkeypatch):
    from agents.bench_controllers import make_controller
    from experiments import distill_labels as dl
    monkeypatch.setattr(dl, "make_expert", lambda settings: make_controller("pi_feedback", kp=-20.0, ki=200.0))


@pytest.fixture
def read_shards():
    """``read(out) -> {shard name: {array name: array}}``, the CPU times left out."""
    def read(out):
        loaded = {}
        for path in sorted((out / "shards").glob("*.npz")):
            with np.load(path, allow_pickle=False) as s:
                loaded[path.name] = {k: s[k] for k in s.files if k not in CPU_TIMES}
        return loaded
    return read


@pytest.fixture
def tiny_labels(tmp_path):
    """A label folder of 6 synthetic started episodes (and one that did not start) whose action is a fixed smooth
    function of the observation, with the ``settings.json`` a label run writes: a student's training data in
    miniature (:mod:`experiments.train_student`)."""
    import json

    from experiments import distill_labels as dl
    folder = tmp_path / "labels"
    (folder / "shards").mkdir(parents=True)
    (folder / "settings.json").write_text(json.dumps({"env_kwargs": {}}))
    rng = np.random.default_rng(5)
    mix = rng.normal(size=(15, 2)).astype(np.float32) / 4
    for draw in range(7):
        steps = 12 + draw
        obs = rng.normal(size=(steps, 15)).astype(np.float32)
        arrays = {**dl.not_started(), "obs": obs, "expert_action": np.tanh(obs @ mix), "started": np.bool_(True),
                  "steps": np.int64(steps), "truth": rng.normal(size=len(dl.TRUTH_NAMES)), "draw": np.int64(draw)}
        if draw == 3:
            arrays = {**dl.not_started(), "truth": np.full(len(dl.TRUTH_NAMES), np.nan), "draw": np.int64(draw)}
        np.savez(dl.shard_path(folder, 20020, draw), **arrays)
    return folder
