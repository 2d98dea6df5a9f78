"""A student trains on a label folder, loads as a bench controller that computes what the trained network
computes, and a resumed training ends bitwise where an uninterrupted one does (:mod:`experiments.train_student`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.student import SPEC, WEIGHTS, StudentController, read_student
from experiments import train_student as ts

SMALL = ts.StudentSettings(hidden=(16, 16), epochs=4, batch=32, val_fraction=0.34, lr=3e-3, aux="truth")


def test_a_student_trains_saves_and_acts_as_its_network(tiny_labels, tmp_path):
    spec = ts.train([tiny_labels], tmp_path / "s", SMALL)
    t = spec["training"]
    assert t["episodes"] == 6 and t["decisions"] == sum(12 + d for d in range(7) if d != 3)
    assert len(t["validation_episodes"]) == 2 and 0 < t["validation_decisions"] < t["decisions"]
    assert [row[0] for row in t["history"]] == [1, 2, 3, 4] and 1 <= t["best_epoch"] <= 4
    assert t["history"][-1][1] < t["history"][0][1]          # the training loss falls
    student = StudentController.load(tmp_path / "s")
    data = ts.dataset(ts.label_shards([tiny_labels]), SMALL)  # the trainer's own inputs
    import torch
    net = ts.build_network(SMALL, len(data.aux_names))
    _, tensors = read_student(tmp_path / "s")
    net.load_state_dict({k.replace("hidden", "hidden.", 1): torch.from_numpy(v) for k, v in tensors.items()
                         if not k.startswith(("obs_", "aux_"))})
    obs = np.load(ts.label_shards([tiny_labels])[0])["obs"]
    student.reset(30.0, None)
    for t_ in range(4):
        action = student.act(obs[t_])
        with torch.no_grad():
            expected, aux = net(torch.from_numpy(data.x[t_:t_ + 1]))
        np.testing.assert_allclose(action, expected.numpy()[0], atol=1e-5)
        np.testing.assert_allclose(student.estimate, aux.numpy()[0] * data.aux_std + data.aux_mean, atol=1e-4)
    assert action.dtype == np.float32 and action.shape == (2,)


def test_a_saved_student_reloads_bitwise(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "s", SMALL)
    first, again = read_student(tmp_path / "s")[1], read_student(tmp_path / "s")[1]
    assert all(np.array_equal(first[k], again[k]) and first[k].dtype == np.float32 for k in first)
    a, b = StudentController.load(tmp_path / "s"), StudentController.load(tmp_path / "s")
    obs = np.load(ts.label_shards([tiny_labels])[0])["obs"]
    for controller in (a, b):
        controller.reset(30.0, None)
    assert all(np.array_equal(a.act(o), b.act(o)) for o in obs)


def test_a_resumed_training_ends_bitwise_where_an_uninterrupted_one_does(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "whole", SMALL)
    assert ts.train([tiny_labels], tmp_path / "cut", SMALL, checkpoint_every=3, stop_after=2) is None
    assert not (tmp_path / "cut" / WEIGHTS).exists()
    ts.train([tiny_labels], tmp_path / "cut", SMALL, checkpoint_every=3)
    assert (tmp_path / "cut" / WEIGHTS).read_bytes() == (tmp_path / "whole" / WEIGHTS).read_bytes()
    whole = json.loads((tmp_path / "whole" / SPEC).read_text())["training"]["history"]
    assert json.loads((tmp_path / "cut" / SPEC).read_text())["training"]["history"] == whole


def test_a_resume_with_other_settings_is_refused_naming_them(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "s", SMALL, stop_after=1)
    other = ts.StudentSettings(**{**ts.asdict(SMALL), "lr": 1e-2})
    with pytest.raises(ValueError, match=r"lr \(stored 0.003, now 0.01\)"):
        ts.train([tiny_labels], tmp_path / "s", other)
