"""Expert labels made by a local process pool are the labels made in one process: the same shards, whichever worker
ran which draw (a scripted stand-in for the expert, inherited by the forked workers: the point is the executor)."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest

from experiments import distill_labels as dl
from triplanar.executor import pool_scope

SHORT = (("time_limit_s", 0.05),)


@pytest.mark.slow
@pytest.mark.skipif(multiprocessing.get_start_method() != "fork", reason="the stand-in reaches workers by fork")
def test_a_process_pool_makes_the_serial_runs_shards(tmp_path, fast_expert, read_shards):
    settings = dl.LabelSettings(env_kwargs=SHORT)
    dl.generate(tmp_path / "serial", settings, 3, 4)
    with pool_scope(2) as pool:
        ran = dl.generate(tmp_path / "pool", settings, 3, 4, pool)
    assert sorted(r["draw"] for r in ran) == [3, 4, 5, 6]
    serial, pooled = read_shards(tmp_path / "serial"), read_shards(tmp_path / "pool")
    assert sorted(serial) == sorted(pooled)
    for name, arrays in serial.items():
        for key, value in arrays.items():
            np.testing.assert_array_equal(pooled[name][key], value, err_msg=f"{name}: {key}")
