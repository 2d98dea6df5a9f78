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
