"""A student's files are refused whole, naming the file and field, when they are not a consistent pair: weights
that are not the ones the spec's SHA-256 names, a spec field of the wrong kind, a tensor of the wrong shape."""

from __future__ import annotations


import numpy as np
import pytest
from safetensors.numpy import save

from agents.student import WEIGHTS, StudentController, StudentFileError


SPEC_OK = {"format": 1, "frames": 2, "hidden": [4], "aux_names": ["tip"], "env_kwargs": {}}


def test_a_consistent_student_loads_and_acts(tmp_path, student_files):
    student_files.write(tmp_path / "s", SPEC_OK, student_files.tensors(SPEC_OK))
    student = StudentController.load(tmp_path / "s")
    student.reset(30.0, None)
    action = student.act(np.zeros(15, dtype=np.float32))
    assert action.shape == (2,) and np.all(np.abs(action) <= 1) and student.estimate.shape == (1,)
    with pytest.raises(ValueError, match="15 bench observations"):
        student.act(np.zeros(14))


def test_inconsistent_student_files_are_refused_naming_what(tmp_path, student_files):
    student_files.write(tmp_path / "s", SPEC_OK, student_files.tensors(SPEC_OK))
    (tmp_path / "s" / WEIGHTS).write_bytes(save({k: v + 1 for k, v in student_files.tensors(SPEC_OK).items()}))
    with pytest.raises(StudentFileError, match="SHA-256 differs"):
        StudentController.load(tmp_path / "s")
    student_files.write(tmp_path / "s", {**SPEC_OK, "hidden": [0]}, student_files.tensors(SPEC_OK))
    with pytest.raises(StudentFileError, match="field 'hidden'"):
        StudentController.load(tmp_path / "s")
    wrong = {**student_files.tensors(SPEC_OK), "action.bias": np.zeros(3, np.float32)}
    student_files.write(tmp_path / "s", SPEC_OK, wrong)
    with pytest.raises(StudentFileError, match=r"tensor 'action.bias' must be finite float32 of shape \(2,\)"):
        StudentController.load(tmp_path / "s")
    with pytest.raises(StudentFileError, match="cannot read"):
        StudentController.load(tmp_path / "nowhere")
