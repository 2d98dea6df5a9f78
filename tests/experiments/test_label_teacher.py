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


def test_a_plain_twin_and_a_teacher_variant_are_recorded_and_a_resume_with_another_is_refused(tmp_path):
    variant = dl.LabelSettings(teacher="limit", expert=(("change_cost", 0.01),), plain_twin=True)
    record = dl.settings_record(variant)
    assert record["plain_twin"] is True and record["expert"]["change_cost"] == 0.01
    assert "plain_twin" not in dl.settings_record(dl.LabelSettings(teacher="limit"))   # older folders resume
    dl.check_settings(tmp_path, variant)
    for other in (dl.LabelSettings(teacher="limit", expert=(("change_cost", 0.02),), plain_twin=True),
                  dl.LabelSettings(teacher="limit", expert=(("change_cost", 0.01),))):
        with pytest.raises(dl.SettingsMismatch, match="expert.change_cost|plain_twin"):
            dl.check_settings(tmp_path, other)
    with pytest.raises(ValueError, match="plain_twin needs teacher 'limit'"):
        dl.LabelSettings(plain_twin=True)


@pytest.mark.slow  # two short episodes of limit beside a plain twin (the twin searches as shipped): about 5 CPU s
def test_the_plain_twin_labels_the_same_states_as_shipped(tmp_path):
    def shard(folder, expert):
        dl.generate(folder, dl.LabelSettings(teacher="limit", expert=expert, env_kwargs=SHORT, plain_twin=True),
                    DRAW, 1)
        with np.load(dl.shard_path(folder, dl.TUNING_SEED, DRAW), allow_pickle=False) as s:
            return s["expert_action"], s["plain_action"], s["action"]
    label, plain, ran = shard(tmp_path / "shipped", ())
    np.testing.assert_array_equal(plain, label)   # the twin is limit as shipped, with the same seed
    label, plain_v, ran = shard(tmp_path / "variant", TINY)
    np.testing.assert_array_equal(ran, label)     # the variant drives round 0
    assert plain_v.shape == label.shape and not np.array_equal(plain_v, label)
    data = dl.load_labels([tmp_path / "variant"], 1, label="plain_action")
    np.testing.assert_array_equal(data["y"], plain_v)
    with pytest.raises(ValueError, match="has no 'plain_action'"):
        dl.generate(tmp_path / "none", dl.LabelSettings(env_kwargs=SHORT, teacher="limit", expert=TINY), DRAW, 1)
        dl.load_labels([tmp_path / "none"], 1, label="plain_action")


def test_a_student_learns_the_plain_twins_labels_only_when_asked():
    from experiments.train_student import StudentSettings
    assert StudentSettings().label == "expert_action"
    assert StudentSettings(label="plain_action").record()["label"] == "plain_action"
    with pytest.raises(ValueError, match="label must be one of"):
        StudentSettings(label="action")
