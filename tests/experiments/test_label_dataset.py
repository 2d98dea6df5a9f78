"""The label rounds' shards load as one training set for a student (DAgger's aggregate): frame-stacked observations
as the robust PPO's policy stacks them, the expert's actions, the privileged row, episode and step indices."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import distill_labels as dl


def test_the_rounds_load_as_one_frame_stacked_training_set(tmp_path):
    obs = np.arange(3 * 15, dtype=np.float32).reshape(3, 15)
    stacked = dl.frame_stacked(obs, 2)
    np.testing.assert_array_equal(stacked[0], np.concatenate([obs[0], obs[0]]))  # padded with the first frame
    np.testing.assert_array_equal(stacked[2], np.concatenate([obs[1], obs[2]]))  # oldest first
    for round_, steps in ((0, 3), (1, 2)):
        folder = tmp_path / f"round{round_}" / "shards"
        folder.mkdir(parents=True)
        arrays = {**dl.not_started(), "obs": obs[:steps], "expert_action": np.ones((steps, 2), np.float32),
                  "truth": np.full(len(dl.TRUTH_NAMES), float(round_)), "started": np.bool_(True),
                  "steps": np.int64(steps)}
        np.savez(folder / "20020_0000001.npz", **arrays)
        np.savez(folder / "20020_0000002.npz", **{**dl.not_started(), "truth": np.zeros(len(dl.TRUTH_NAMES))})
    data = dl.load_labels([tmp_path / "round0", tmp_path / "round1"], frames=2)
    assert data["x"].shape == (5, 30) and data["y"].shape == (5, 2)
    np.testing.assert_array_equal(data["episode"], [0, 0, 0, 1, 1])
    np.testing.assert_array_equal(data["step"], [0, 1, 2, 0, 1])
    np.testing.assert_array_equal(data["truth"][:, 0], [0, 0, 0, 1, 1])
    with pytest.raises(ValueError, match="no started episode"):
        dl.load_labels([tmp_path / "nothing"])
