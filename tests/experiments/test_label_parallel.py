"""Expert labels made by a local process pool are the labels made in one process: the same shards, whichever worker
ran which draw (a scripted stand-in for the expert, inherited by the forked workers: the point is the executor)."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from agents.bench_controllers import make_controller
from experiments import distill_labels as dl
from triplanar.executor import pool_scope

SHORT = (("time_limit_s", 0.05),)
TIMES = ("expert_cpu_s", "episode_cpu_s")


def shards(out):
    loaded = {}
    for path in sorted((out / "shards").glob("*.npz")):
        with np.load(path, allow_pickle=False) as s:
            loaded[path.name] = {k: s[k] for k in s.files if k not in TIMES}
    return loaded


@pytest.mark.slow
@pytest.mark.skipif(multiprocessing.get_start_method() != "fork", reason="the stand-in reaches workers by fork")
def test_a_process_pool_makes_the_serial_runs_shards(tmp_path, monkeypatch):
    monkeypatch.setattr(dl, "make_expert", lambda settings: make_controller("pi_feedback", kp=-20.0, ki=200.0))
    settings = dl.LabelSettings(env_kwargs=SHORT)
    dl.generate(tmp_path / "serial", settings, 3, 4)
    with pool_scope(2) as pool:
        ran = dl.generate(tmp_path / "pool", settings, 3, 4, pool)
    assert sorted(r["draw"] for r in ran) == [3, 4, 5, 6]
    serial, pooled = shards(tmp_path / "serial"), shards(tmp_path / "pool")
    assert sorted(serial) == sorted(pooled)
    for name, arrays in serial.items():
        for key, value in arrays.items():
            np.testing.assert_array_equal(pooled[name][key], value, err_msg=f"{name}: {key}")
