"""A student is judged on the tuning stream's draws below 1000, which no label run uses by default: the benches
``random_benches`` draws first (the ones the tuning rounds' ``mpc`` figures come from), never a labelled draw."""

from __future__ import annotations

import numpy as np
import pytest

from agents.heldout import TUNING_SEED, random_benches
from experiments import train_student as ts
from experiments.distill_labels import parse_args


def test_the_judging_draws_are_the_first_tuning_benches_below_the_labels(monkeypatch):
    found = ts.judge_draws(3, {})
    assert [d for d, _ in found] == sorted(d for d, _ in found) and found[-1][0] < ts.JUDGE_DRAWS
    assert ts.JUDGE_DRAWS == parse_args(["--out", "x"]).first   # labels start where judging stops
    for (_, bench), same in zip(found, random_benches(3, TUNING_SEED)):
        np.testing.assert_array_equal(bench.specimen.friction_deg, same.specimen.friction_deg)
        assert bench.load_N == same.load_N
    monkeypatch.setattr(ts, "JUDGE_DRAWS", 4)
    with pytest.raises(ValueError, match=r"--judge 3: only \d draws below 4 start"):
        ts.judge_draws(3, {})
