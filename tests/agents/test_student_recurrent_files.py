"""A recurrent student's files load (and the first students', without the new layout fields, still do), and a
tampered or inconsistent recurrent student is refused whole, naming the file and field (:mod:`agents.student`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.student import SPEC, WEIGHTS, StudentController, StudentFileError, tensor_shapes

GRU_SPEC = {"format": 1, "frames": 1, "hidden": [4], "aux_names": [], "env_kwargs": {}, "kind": "gru", "gru": 3,
            "start": [[0.1, -0.1]]}


def test_a_recurrent_student_loads_and_carries_its_state(tmp_path, student_files):
    assert tensor_shapes(GRU_SPEC)["gru.weight_hh"] == (9, 3)
    student = StudentController.load(student_files.write(tmp_path / "s", GRU_SPEC))
    student.reset(30.0, None)
    obs = np.ones(15, dtype=np.float32)
    assert student.act(obs).tolist() == np.float32([0.1, -0.1]).tolist()   # the start's action
    second, third = student.act(obs), student.act(obs)
    assert second.shape == (2,) and not np.array_equal(second, third)       # same input, the state moved
    student.reset(30.0, None)
    student.act(obs)
    assert np.array_equal(student.act(obs), second)


def test_a_tampered_recurrent_student_is_refused(tmp_path, student_files):
    folder = student_files.write(tmp_path / "s", GRU_SPEC)
    blob = bytearray((folder / WEIGHTS).read_bytes())
    blob[-1] ^= 1
    (folder / WEIGHTS).write_bytes(bytes(blob))
    with pytest.raises(StudentFileError, match="SHA-256 differs"):
        StudentController.load(folder)
    tensors = student_files.tensors(GRU_SPEC)
    student_files.write(folder, {**GRU_SPEC, "gru": 4}, tensors)
    with pytest.raises(StudentFileError, match=r"tensor 'gru.weight_ih' must be finite float32 of shape \(12, 15\)"):
        StudentController.load(folder)
    for field, value in (("kind", "lstm"), ("gru", 0), ("start", [[2.0, 0.0]])):
        student_files.write(folder, {**GRU_SPEC, field: value}, tensors)
        with pytest.raises(StudentFileError, match=f"field '{field}'"):
            StudentController.load(folder)


def test_a_student_without_the_new_fields_loads_as_a_frame_stack(tmp_path, student_files):
    spec = {"format": 1, "frames": 2, "hidden": [4], "aux_names": [], "env_kwargs": {}}
    folder = student_files.write(tmp_path / "s", spec)
    assert "kind" not in json.loads((folder / SPEC).read_text())
    student = StudentController.load(folder)
    student.reset(30.0, None)
    obs = np.ones(15, dtype=np.float32)
    assert np.array_equal(student.act(obs), student.act(obs))   # no state beyond the (full) frame stack
