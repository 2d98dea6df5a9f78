"""An expert-label shard is deterministic per draw: the same draw of the stream, labelled twice by ``mpc`` (tiny
settings, a short episode), gives the same arrays but the CPU times; round 0's labels are what ran, and the episode
is the one :func:`agents.heldout.run_episode` runs with the same controller on the same bench and noise seed. A
later round's driver runs, with the expert's action in a fraction ``beta`` of the periods."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.heldout import run_episode
from agents.mpc import MPCController
from experiments import distill_labels as dl

TINY = (("bank_size", 4), ("elites", 2), ("horizon", 8), ("hypotheses", 2), ("iterations", 1),
        ("refine_evaluations", 4), ("refine_every", 5), ("samples", 8), ("start_periods", 2))
SHORT = (("time_limit_s", 0.05),)
DRAW = 3  # a draw of the tuning stream that starts
TIMES = ("expert_cpu_s", "episode_cpu_s")


def load(path):
    with np.load(path, allow_pickle=False) as s:
        return {k: s[k] for k in s.files}


@pytest.mark.slow
def test_a_shard_is_deterministic_per_draw_and_holds_mpc_episode(tmp_path):
    settings = dl.LabelSettings(expert=TINY, env_kwargs=SHORT)
    for run in ("a", "b"):
        dl.generate(tmp_path / run, settings, DRAW, 1)
    a, b = (load(dl.shard_path(tmp_path / run, dl.TUNING_SEED, DRAW)) for run in ("a", "b"))
    assert sorted(a) == sorted(b)
    for key in a:
        if key not in TIMES:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    steps = int(a["steps"])
    assert bool(a["started"]) and steps == len(a["obs"]) == len(a["expert_action"]) == len(a["expert_cpu_s"]) > 2
    assert a["obs"].shape[1] == len(a["obs_names"]) == 15
    np.testing.assert_array_equal(a["action"], a["expert_action"])  # round 0: the expert drove
    assert a["expert_ran"].all() and np.isfinite(a["expert_estimate"][-1]).all()

    bench = dl.bench_of_draw(dl.TUNING_SEED, DRAW, dict(SHORT))
    np.testing.assert_array_equal(a["truth"], dl.bench_truth(bench))
    outcome = run_episode(MPCController(**dict(TINY)), bench, env_kwargs=dict(SHORT), seed=int(a["noise_seed"]))
    assert outcome.steps == steps and outcome.reason == str(a["reason"])
    assert math.isclose(outcome.travel_m, float(a["travel_m"][-1]), rel_tol=0.0, abs_tol=0.0)


@pytest.mark.slow
def test_a_later_round_labels_the_drivers_states(tmp_path):
    settings = dl.LabelSettings(round=1, driver="pi_feedback", beta=0.5, expert=TINY, env_kwargs=SHORT)
    dl.generate(tmp_path, settings, DRAW, 1)
    s = load(dl.shard_path(tmp_path, dl.TUNING_SEED, DRAW))
    ran = s["expert_ran"]
    assert ran.any() and not ran.all()
    np.testing.assert_array_equal(s["action"][ran], s["expert_action"][ran])
    assert np.any(s["action"][~ran] != s["expert_action"][~ran])  # the driver's own actions ran in the others
    with pytest.raises(ValueError, match="round 0 is driven by the expert"):
        dl.LabelSettings(round=1)
