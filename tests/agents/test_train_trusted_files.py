"""``triplanar train`` loads no file the user did not name: a pickle planted at the default output folder never
runs, checkpoint statistics are plain arrays (a pickle in their place is refused, not run), and a checkpoint is one
consistent set (model and statistics of another step count are refused by name)."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from triplanar import cli

pytest.importorskip("stable_baselines3")

TINY = ["--set", "n_envs=2", "--set", "hyperparams.n_steps=64", "--set", "hyperparams.batch_size=64",
        "--set", "hyperparams.n_epochs=1", "--set", "train.checkpoint_freq=128", "--set", "train.eval_freq=100000",
        "--env-arg", "start_bank=4", "--executor", "serial", "--no-progress"]


class Payload:
    """Unpickling this writes the marker file: the proof that a planted pickle ran."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return exec, (f"open({str(self.marker)!r}, 'w').write('ran')",)


def plant(path: Path, marker: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(Payload(marker)))


def plant_every_default_path(root: Path, marker: Path) -> None:
    for folder in ("runs/robust", "runs/recurrent", "runs/ppo"):
        run = root / folder / "seed_0"
        for name in ("checkpoint/vecnormalize.pkl", "checkpoint/model.zip", "checkpoint/model_2048.zip",
                     "checkpoint/vecnormalize_2048.npz", "checkpoints/ppo_2048_steps.zip",
                     "checkpoints/ppo_vecnormalize_2048_steps.pkl", "checkpoints/ppo_vecnormalize_2048_steps.npz"):
            plant(run / name, marker)
        (run / "checkpoint" / "state.json").write_text(json.dumps(
            {"timesteps": 2048, "wall_s": 1.0, "curve": [], "model": "model_2048.zip",
             "vecnormalize": "vecnormalize_2048.npz", "token": ""}))
        for name in ("tasks/0123456789abcdef0123456789abcdef.pkl", "tasks/0123456789abcdef0123456789abcdef.npz"):
            plant(root / folder / name, marker)


@pytest.mark.parametrize("argv", [
    ["--env", "TriPlanarShear-v1"],
    ["--env", "TriPlanarShear-v1", "--algo", "recurrent"],
    ["--env", "TriPlanarShear-v0"],
])
def test_planted_pickles_at_the_default_folder_never_run(argv, tmp_path, monkeypatch, capsys) -> None:
    marker = tmp_path / "marker"
    monkeypatch.chdir(tmp_path)
    plant_every_default_path(tmp_path, marker)
    assert cli.main(["train", *argv, "--timesteps", "128", "--executor", "serial", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "holds checkpoints of an earlier run" in err and "--resume" in err and "Traceback" not in err
    assert not marker.exists()


def test_a_pickle_in_place_of_the_statistics_is_refused_not_run(tmp_path) -> None:
    from agents.checkpoint_files import CheckpointError, read_normalizer
    marker = tmp_path / "marker"
    plant(tmp_path / "vecnormalize_2048.npz", marker)
    with pytest.raises(CheckpointError, match="vecnormalize_2048.npz: not a normalisation-statistics file"):
        read_normalizer(tmp_path / "vecnormalize_2048.npz")
    assert not marker.exists()
    truncated = tmp_path / "vecnormalize_4096.npz"   # a torn write: a named error (it used to be a traceback)
    np.savez(truncated, obs_mean=np.zeros(15), obs_var=np.ones(15))
    truncated.write_bytes(truncated.read_bytes()[:200])
    with pytest.raises(CheckpointError, match="vecnormalize_4096.npz: not a normalisation-statistics file"):
        read_normalizer(truncated)


@pytest.mark.slow
def test_a_checkpoint_is_one_set_and_a_foreign_one_is_refused(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    argv = ["train", "--env", "TriPlanarShear-v1", "--timesteps", "384", "--out", str(out), *TINY]
    assert cli.main(argv) == 0
    ckpt = out / "seed_0" / "checkpoint"
    state = json.loads((ckpt / "state.json").read_text())
    files = sorted(p.name for p in ckpt.iterdir())
    assert files == sorted([state["model"], state["vecnormalize"], "state.json"])   # the previous sets removed
    assert not list(ckpt.glob("*.pkl"))
    stats = np.load(ckpt / state["vecnormalize"], allow_pickle=False)
    assert int(stats["timesteps"]) == state["timesteps"]
    # a kill between the files of the next set: a newer model beside the older statistics and state.json
    (ckpt / "model_99999.zip").write_bytes((ckpt / state["model"]).read_bytes())
    # state.json pointing at statistics of another step count (what the 40,960 / 20,480 case was)
    other = dict(state, timesteps=state["timesteps"] + 128)
    (ckpt / "state.json").write_text(json.dumps(other))
    (out / "seed_0" / "done.json").unlink()
    assert cli.main([*argv[:4], "768", *argv[5:]]) == 2
    assert f"statistics of step {state['timesteps']}" in capsys.readouterr().err
    # the same set named correctly resumes; without --out (not named) a foreign token is refused
    (ckpt / "state.json").write_text(json.dumps(state))
    assert cli.main([*argv[:4], "512", *argv[5:]]) == 0
    assert json.loads((out / "seed_0" / "done.json").read_text())["timesteps"] >= 512


@pytest.mark.parametrize("extra, message", [([], "holds an earlier run"), (["--skip-train"], "name the folder")])
def test_study_loads_no_run_from_the_default_ppo_dir(extra, message, tmp_path, monkeypatch, capsys) -> None:
    marker = tmp_path / "marker"
    monkeypatch.chdir(tmp_path)
    plant_every_default_path(tmp_path, marker)
    for name in ("final_model.zip", "vecnormalize.pkl"):
        plant(tmp_path / "runs" / "ppo" / "seed_0" / name, marker)
    (tmp_path / "runs" / "ppo" / "seed_0" / "done.json").write_text(json.dumps({"timesteps": 10**9, "wall_s": 1.0}))
    assert cli.main(["study", "--out", str(tmp_path / "study"), "--seeds", "0", "--executor", "serial", *extra]) == 2
    assert message in capsys.readouterr().err
    assert not marker.exists()
