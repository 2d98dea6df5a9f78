"""Labels from the privileged teacher ``limit`` (``--teacher limit``): its settings and source are what the folder
records (an ``mpc`` folder's record has no teacher field, as before there was one), and its shard is its episode."""

from __future__ import annotations

import numpy as np
import pytest

from agents.heldout import run_episode
from agents.limit import LimitController
from experiments import distill_labels as dl

TINY = (("horizon", 8), ("iterations", 1), ("samples", 8), ("elites", 2))
SHORT = (("time_limit_s", 0.05),)
DRAW = 3  # a draw of the tuning stream that starts


def test_the_teacher_is_recorded_only_where_it_is_not_mpc():
    mpc, limit = dl.settings_record(dl.LabelSettings()), dl.settings_record(dl.LabelSettings(teacher="limit"))
    assert "teacher" not in mpc and "agents/limit.py" not in mpc["code_version"]
    assert limit["teacher"] == "limit" and "agents/limit.py" in limit["code_version"]
    assert limit["expert"]["horizon"] == LimitController.horizon and "needs_env" not in limit["expert"]
    with pytest.raises(ValueError, match="teacher must be one of"):
        dl.LabelSettings(teacher="oracle")
    with pytest.raises(ValueError, match=r"\['bank_size'\] are not LimitController settings"):
        dl.LabelSettings(teacher="limit", expert=(("bank_size", 4),))


@pytest.mark.slow  # a short episode of limit (tiny search): about 2 CPU s
def test_a_limit_shard_is_limits_episode(tmp_path):
    dl.generate(tmp_path, dl.LabelSettings(teacher="limit", expert=TINY, env_kwargs=SHORT), DRAW, 1)
    with np.load(dl.shard_path(tmp_path, dl.TUNING_SEED, DRAW), allow_pickle=False) as s:
        steps, reason, action, label = int(s["steps"]), str(s["reason"]), s["action"], s["expert_action"]
        seed, estimate = int(s["noise_seed"]), s["expert_estimate"]
    np.testing.assert_array_equal(action, label)
    assert np.isnan(estimate).all()   # limit estimates nothing: it knows
    bench = dl.bench_of_draw(dl.TUNING_SEED, DRAW, dict(SHORT))
    outcome = run_episode(LimitController(**dict(TINY)), bench, env_kwargs=dict(SHORT), seed=seed)
    assert outcome.steps == steps > 2 and outcome.reason == reason
