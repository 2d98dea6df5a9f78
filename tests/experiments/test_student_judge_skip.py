"""``train_student --judge N --judge-skip M`` judges the same benches, with the same noise seeds, as the last
``N - M`` of ``--judge N`` (the second set kept for reporting a choice made on the first)."""

from __future__ import annotations

import pytest

from experiments import train_student as ts


@pytest.mark.slow   # three episodes and a training: about 5 s
def test_a_skipped_judge_is_the_tail_of_the_whole_one(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "s", ts.StudentSettings(hidden=(8,), epochs=1, batch=64, val_fraction=0.34))
    whole, tail = ts.judge(tmp_path / "s", 2), ts.judge(tmp_path / "s", 2, skip=1)
    assert (whole["n_episodes"], tail["n_episodes"]) == (2, 1)
    assert tail["failures"] == [f for f in whole["failures"] if f[0] >= 1]
    assert tail["success_rate"] == (1.0 if not tail["failures"] else 0.0)
