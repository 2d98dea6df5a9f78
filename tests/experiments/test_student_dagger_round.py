"""A trained student drives a later DAgger round (``--round 1 --driver student:DIR``): ``controller_of`` loads it as
a learned controller, and the round's shard holds the student's own actions, the expert's labels beside them."""

from __future__ import annotations

import numpy as np
import pytest

from agents.student import StudentController
from experiments import distill_labels as dl
from experiments import train_student as ts
from experiments.episodes import EpisodeBatch, controller_of

SMALL = ts.StudentSettings(hidden=(8,), epochs=2, batch=32, val_fraction=0.0)
SHORT = (("time_limit_s", 0.05),)
DRAW = 3  # a draw of the tuning stream that starts


@pytest.mark.slow  # an env episode and the bench's start check: about 2 CPU s
def test_a_student_drives_a_dagger_round(tiny_labels, tmp_path, fast_expert):
    ts.train([tiny_labels], tmp_path / "student", SMALL)
    student, env_kwargs, learned = controller_of(EpisodeBatch(label="s", controller=f"student:{tmp_path / 'student'}"))
    assert isinstance(student, StudentController) and learned and env_kwargs == {} and student.name == "s"

    settings = dl.LabelSettings(round=1, driver=f"student:{tmp_path / 'student'}", env_kwargs=SHORT)
    dl.generate(tmp_path / "round1", settings, DRAW, 1)
    with np.load(dl.shard_path(tmp_path / "round1", dl.TUNING_SEED, DRAW), allow_pickle=False) as s:
        obs, action, label, ran = s["obs"], s["action"], s["expert_action"], s["expert_ran"]
    assert len(obs) > 2 and not ran.any()                  # beta 0: the student ran every period
    student.reset(0.0, None)
    np.testing.assert_array_equal(action, np.array([student.act(o) for o in obs]))
    assert np.any(action != label)                         # and the expert's labels are its own
