"""benchmarks/bench_banked.py: a shadow bank beside ``banked:RUN``'s (``--shadow``) sees the same closed loop; one
with the controller's own settings estimates exactly as the controller's, a richer one differently; bad shadow
settings are refused by name; a tracker shadow follows the same loop, its bank's estimate until it starts."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_banked import episode, shadow_bank, summary, tracker_counts

from agents.banked_deviation import BankedDeviationPolicy
from agents.heldout import nominal_benches
from agents.mpc import MPCController
from agents.robust_policy import DeviationPolicy


def _controller(recording_model):
    recorder = recording_model(lambda x: np.array([0.4, 0.1 * np.tanh(1e3 * x[45])], dtype=np.float32))
    return BankedDeviationPolicy(DeviationPolicy(recorder, recorder), MPCController(bank_size=3, refine_every=0))


def test_a_shadow_with_the_controllers_settings_estimates_as_the_controller_and_a_refining_one_does_not(
        recording_model):
    bench = nominal_benches((40.0,))[0]
    same = episode(_controller(recording_model), bench, 1, shadow_bank("3,0,-1"))
    assert len(same) > 10 and all(len(r) == 5 for r in same)
    assert [r[3] for r in same] == [r[2] for r in same]   # the same bank, fed the same periods
    richer = episode(_controller(recording_model), bench, 1, shadow_bank("3,4,-1"))
    assert [r[2] for r in richer] == [r[2] for r in same]   # the shadow does not drive
    assert [r[3] for r in richer] != [r[2] for r in richer]
    out = summary([same, richer])
    assert out["decisions"] == len(same) + len(richer) and out["shadow_cpu_mean_ms"] > 0
    assert out["shadow_error_mm_decisions_0_8"] is not None


def test_a_tracker_shadow_follows_the_same_loop_and_counts_its_refits(recording_model):
    bench = nominal_benches((40.0,))[0]
    plain = episode(_controller(recording_model), bench, 1, shadow_bank("3,0,-1"))
    tracker = shadow_bank("tracker:4,3,2,2,0", bank_size=3)
    tracked = episode(_controller(recording_model), bench, 1, tracker)
    assert [r[2] for r in tracked] == [r[2] for r in plain]   # the shadow does not drive
    assert [r[3] for r in tracked[:4]] == [r[3] for r in plain[:4]]   # its bank's estimate until it starts
    assert [r[3] for r in tracked] != [r[3] for r in plain]
    counts = tracker_counts(tracker)
    assert counts["refits"] >= 1 and counts["replays"] >= 4 and tracker_counts(shadow_bank("3,0,-1")) == {}


@pytest.mark.parametrize("text", ["3,0", "a,b,c", "0,0,-1", "3,-1,0", "3,0,-2", "tracker:6,4,2", "tracker:0,4,2,2,0",
                                  "tracker:6,4,2,2,-1", "tracker:a"])
def test_bad_shadow_settings_are_refused_naming_the_option(text):
    with pytest.raises(ValueError, match="--shadow"):
        shadow_bank(text)
    assert shadow_bank(None) is None
