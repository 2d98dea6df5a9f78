"""A recurrent student (``--kind gru``) trains on whole episodes, its numpy forward at run time equals torch's on a
recorded episode, its training resumes bitwise, and ``--start-periods`` plays ``mpc``'s excitation first and leaves
those decisions out of the loss (:mod:`experiments.train_student`, :mod:`agents.student`)."""

from __future__ import annotations

import numpy as np

from agents.student import WEIGHTS, StudentController, read_student
from experiments import train_student as ts

GRU = ts.StudentSettings(kind="gru", gru=8, hidden=(8,), frames=2, epochs=3, batch=2, val_fraction=0.34, lr=3e-3)


def test_a_recurrent_student_acts_as_its_torch_network_over_a_whole_episode(tiny_labels, tmp_path):
    import torch
    spec = ts.train([tiny_labels], tmp_path / "s", GRU)
    assert spec["kind"] == "gru" and spec["gru"] == 8 and "start" not in spec
    history = spec["training"]["history"]
    assert history[-1][1] < history[0][1]                     # the training loss falls
    data = ts.dataset(ts.label_shards([tiny_labels]), GRU)
    net = ts.build_network(GRU, 0)
    net.load_state_dict({ts.torch_name(k): torch.from_numpy(v) for k, v in read_student(tmp_path / "s")[1].items()
                         if not k.startswith("obs_")})
    with torch.no_grad():
        expected = net(ts.episode_batch(data, np.array([1]))[0])[0].numpy()[0]
    obs = np.load(ts.label_shards([tiny_labels])[1])["obs"]
    student = StudentController.load(tmp_path / "s")
    for _ in range(2):   # a reset starts the recurrent state from zero again
        student.reset(30.0, None)
        actions = np.array([student.act(o) for o in obs])
        np.testing.assert_allclose(actions, expected, atol=1e-5)
    assert not np.allclose(actions[-1], actions[-2])


def test_a_resumed_recurrent_training_ends_bitwise(tiny_labels, tmp_path):
    ts.train([tiny_labels], tmp_path / "whole", GRU)
    assert ts.train([tiny_labels], tmp_path / "cut", GRU, checkpoint_every=2, stop_after=1) is None
    ts.train([tiny_labels], tmp_path / "cut", GRU, checkpoint_every=2)
    assert (tmp_path / "cut" / WEIGHTS).read_bytes() == (tmp_path / "whole" / WEIGHTS).read_bytes()


def test_start_periods_play_the_excitation_and_are_not_learnt(tiny_labels, tmp_path):
    settings = ts.StudentSettings(**{**ts.asdict(GRU), "start_periods": 3})
    data = ts.dataset(ts.label_shards([tiny_labels]), settings)
    steps = np.concatenate([np.arange(b - a) for a, b in zip(data.bounds[:-1], data.bounds[1:])])
    assert np.all(steps[np.concatenate([data.train, data.val])] >= 3) and not data.learnt[steps < 3].any()
    spec = ts.train([tiny_labels], tmp_path / "s", settings)
    assert spec["start"] == ts.mpc_start(3, {}) and len(spec["start"]) == 3
    student = StudentController.load(tmp_path / "s")
    student.reset(30.0, None)
    obs = np.load(ts.label_shards([tiny_labels])[0])["obs"]
    played = [student.act(o) for o in obs[:4]]
    assert [a.tolist() for a in played[:3]] == [np.float32(spec["start"][k]).tolist() for k in range(3)]
    assert played[3].tolist() not in [np.float32(a).tolist() for a in spec["start"]]
