"""``experiments.student_diagnosis --validation``: the shards of exactly the episodes a student held out of its
training (counted over the started shards its run read), and a privileged student replayed with its truth."""

from __future__ import annotations

import numpy as np

from experiments import student_diagnosis as sd
from experiments import train_student as ts

SMALL = ts.StudentSettings(hidden=(8,), epochs=1, batch=32, val_fraction=0.34, given="truth")


def test_the_validation_shards_are_the_held_out_episodes(tiny_labels, tmp_path):
    for path in ts.label_shards([tiny_labels]):   # the fixture's shards ran no action: the label ran
        arrays = dict(np.load(path))
        arrays["action"] = arrays["expert_action"]
        np.savez(path, **arrays)
    spec = ts.train([tiny_labels], tmp_path / "s", SMALL)
    shards = sd.validation_shards(tmp_path / "s")
    started = [p for p in ts.label_shards([tiny_labels]) if bool(np.load(p)["started"])]
    assert shards == [started[k] for k in spec["training"]["validation_episodes"]] and len(shards) == 2
    out = sd.diagnose([], sd.StudentController.load(tmp_path / "s"), shards)
    assert out["episodes"] == 2
    assert all(np.isfinite(row["student_vs_label_rms"]) for row in out["spans"] if row["n"])
