"""A privileged student (``--given truth``, :mod:`experiments.train_student`): the bench's true unknowns appended to
its input, saved as ``given_names`` in its file, read back by :class:`agents.student.StudentController` exactly as the
trainer feeds them, and refused when they are not set."""

from __future__ import annotations

import numpy as np
import pytest

from agents.student import StudentController, read_student
from experiments import train_student as ts
from experiments.distill_labels import TRUTH_NAMES

SMALL = ts.StudentSettings(hidden=(8,), epochs=2, batch=32, val_fraction=0.34, given="truth")


def test_the_truth_is_appended_to_the_input_and_read_back_as_trained(tiny_labels, tmp_path):
    import torch
    data = ts.dataset(ts.label_shards([tiny_labels]), SMALL)
    assert data.given_names == list(TRUTH_NAMES) and data.x.shape[1] == 4 * 15 + len(TRUTH_NAMES)
    spec = ts.train([tiny_labels], tmp_path / "s", SMALL)
    assert spec["given_names"] == list(TRUTH_NAMES)
    net = ts.build_network(SMALL, 0, len(TRUTH_NAMES))
    _, tensors = read_student(tmp_path / "s")
    net.load_state_dict({k.replace("hidden", "hidden.", 1): torch.from_numpy(v) for k, v in tensors.items()
                         if not k.startswith("obs_")})
    shard = np.load(ts.label_shards([tiny_labels])[0])
    student = StudentController.load(tmp_path / "s")
    student.reset(30.0, None)
    student.given = shard["truth"]
    for t in range(3):
        with torch.no_grad():
            expected, _ = net(torch.from_numpy(data.x[t:t + 1]))
        np.testing.assert_allclose(student.act(shard["obs"][t]), expected.numpy()[0], atol=1e-5)


def test_a_privileged_student_without_its_inputs_is_refused(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "s", SMALL)
    student = StudentController.load(tmp_path / "s")
    student.reset(30.0, None)
    obs = np.load(ts.label_shards([tiny_labels])[0])["obs"][0]
    with pytest.raises(ValueError, match="given"):
        student.act(obs)
    student.given = np.zeros(3)
    with pytest.raises(ValueError, match="given"):
        student.act(obs)


@pytest.mark.parametrize("bad", [{"given": "estimate"}, {"given": "truth", "kind": "gru"}])
def test_a_bad_given_is_refused_naming_it(bad):
    with pytest.raises(ValueError, match="given"):
        ts.StudentSettings(**bad)
