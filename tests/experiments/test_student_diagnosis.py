"""The diagnosis of a student's departures (:mod:`experiments.student_diagnosis`): per span of decisions the labels'
spread and the error of what ran against them, and each failed episode's reason, length and first departure."""

from __future__ import annotations

import numpy as np

from experiments import distill_labels as dl
from experiments.student_diagnosis import diagnose


def test_spans_and_failures_are_read_from_the_shards(tmp_path):
    (tmp_path / "shards").mkdir()
    for draw, (success, gap_from) in enumerate([(True, 99), (False, 2)]):
        label = np.tile(np.float32([[0.1, -0.1], [0.3, 0.1]]), (10, 1))      # 20 decisions, spread 0.1 per component
        ran = label.copy()
        ran[gap_from:] += np.float32([0.5, 0.0])
        np.savez(dl.shard_path(tmp_path, 20020, draw), **{
            **dl.not_started(), "obs": np.zeros((20, 15), np.float32), "expert_action": label, "action": ran,
            "started": np.bool_(True), "steps": np.int64(20), "success": np.bool_(success),
            "reason": np.str_("travel" if success else "left_plane")})
    np.savez(dl.shard_path(tmp_path, 20020, 2), **dl.not_started())
    out = diagnose([tmp_path], None)
    assert out["episodes"] == 2
    assert out["failures"] == [{"shard": "20020_0000001.npz", "reason": "left_plane", "steps": 20,
                                "first_departure": 2}]
    first, second, third = out["spans"][:3]
    assert out["spans"][-1]["n"] == 0 and np.isnan(out["spans"][-1]["label_spread_rms"])   # no decision 32 or later
    assert first["n"] == 2 and third["n"] == 4 and third["decisions"] == "2-3"
    np.testing.assert_allclose([first["label_spread_rms"], third["label_spread_rms"]], [0.0, 0.1], atol=1e-6)
    assert first["ran_vs_label_rms"] == 0.0 and second["ran_vs_label_rms"] == 0.0
    np.testing.assert_allclose(third["ran_vs_label_rms"], np.sqrt(0.5 ** 2 / 4), atol=1e-6)   # half the rows, x only
