"""A ``train`` that fails before its first checkpoint leaves a ``config.json`` that does not refuse the corrected
rerun into the same ``--out`` (it binds a folder only once there is a checkpoint or a finished run to continue)."""

from __future__ import annotations

import json

import pytest

from triplanar import cli

pytest.importorskip("stable_baselines3")


class Reached(Exception):
    pass


def test_the_corrected_rerun_is_not_refused(tmp_path, monkeypatch) -> None:
    import agents.trainer as trainer

    def fails(task, config, run_dir):
        raise Reached(config["hyperparams"]["learning_rate"])
    monkeypatch.setattr(trainer, "_start_or_resume", fails)
    argv = ["train", "--env", "TriPlanarShear-v1", "--timesteps", "64", "--out", str(tmp_path), "--executor",
            "serial", "--no-progress"]
    with pytest.raises(Reached):
        cli.main([*argv, "--set", "hyperparams.learning_rate=0.5"])
    assert json.loads((tmp_path / "seed_0" / "config.json").read_text())["hyperparams"]["learning_rate"] == 0.5
    with pytest.raises(Reached, match="0.001"):   # before: exit 2, "holds a run trained with another hyperparams"
        cli.main([*argv, "--set", "hyperparams.learning_rate=0.001"])
