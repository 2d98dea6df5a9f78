"""``triplanar train`` reports as SB3 does: ``--verbose 1`` prints SB3's table, ``--tensorboard-log DIR`` holds the
episodes' return, length, success and error beside SB3's losses and the evaluations, the learning curve has points
at a default frequency, and ``--no-progress`` leaves no bar at all (tiny budgets)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from triplanar import cli

pytest.importorskip("stable_baselines3")
pytest.importorskip("tensorboard")

V1_TINY = ["--set", "n_envs=4", "--set", "hyperparams.n_steps=64", "--set", "hyperparams.batch_size=128",
           "--set", "hyperparams.n_epochs=1", "--env-arg", "start_bank=4"]


def tags(log_dir: Path) -> set[str]:
    """Every scalar tag written under ``log_dir`` (all runs)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    found: set[str] = set()
    for events in log_dir.rglob("events.out.tfevents.*"):
        accumulator = EventAccumulator(str(events))
        accumulator.Reload()
        found.update(accumulator.Tags()["scalars"])
    return found


def no_bar(stderr: str) -> bool:
    return "%|" not in stderr and "step/s" not in stderr and " seeds" not in stderr


@pytest.mark.slow
def test_v1_training_reports_its_episodes_losses_and_evaluations(tmp_path, capsys, monkeypatch) -> None:
    from agents import run_benches
    monkeypatch.setattr(run_benches, "CURVE_BENCHES", 1)   # one tuning bench per point of the curve: cheap
    code = cli.main(["train", "--env", "TriPlanarShearRealistic-v0", "--timesteps", "1024",
                     "--out", str(tmp_path / "run"), "--executor", "serial", "--no-progress", "--verbose", "1",
                     "--tensorboard-log", str(tmp_path / "tb"), *V1_TINY])
    out, err = capsys.readouterr()
    assert code == 0, err
    for key in ("rollout/", "ep_rew_mean", "ep_len_mean", "success_rate", "train/", "value_loss", "eval/"):
        assert key in out   # SB3's table (--verbose 1)
    assert no_bar(err), err[-2000:]
    written = tags(tmp_path / "tb")
    assert (tmp_path / "tb" / "ppo_robust_seed0_1").is_dir()
    for tag in ("rollout/ep_rew_mean", "rollout/ep_len_mean", "rollout/success_rate", "rollout/success_episodes",
                "train/value_loss", "train/policy_gradient_loss", "eval/score"):
        assert tag in written, sorted(written)
    with open(tmp_path / "run" / "seed_0" / "learning_curve.csv") as f:
        steps = [int(row["timesteps"]) for row in csv.DictReader(f)]
    # the default frequency: 20 points over the run, at least a rollout (4 x 64 = 256 steps) apart
    assert len(steps) >= 5 and steps == sorted(steps) and steps[-1] == 1024, steps


@pytest.mark.slow
def test_v0_training_writes_tensorboard_where_asked_and_prints_sb3s_table(tmp_path, capsys) -> None:
    code = cli.main(["train", "--timesteps", "2048", "--out", str(tmp_path / "run"), "--executor", "serial",
                     "--no-progress", "--verbose", "1", "--tensorboard-log", str(tmp_path / "tb"),
                     "--set", "n_envs=4", "--set", "ppo.n_steps=128", "--set", "ppo.batch_size=128",
                     "--set", "ppo.n_epochs=1", "--eval-freq", "512", "--set", "eval_loads=[40.0]"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "ep_rew_mean" in out and "value_loss" in out and no_bar(err)
    assert (tmp_path / "tb" / "ppo_seed0_1").is_dir() and not (tmp_path / "run" / "seed_0" / "tb").exists()
    written = tags(tmp_path / "tb")
    for tag in ("rollout/ep_rew_mean", "rollout/success_rate", "train/value_loss", "mimicry/mean_error_mm"):
        assert tag in written, sorted(written)


def test_verbose_takes_sb3s_levels_only(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit):
        cli.main(["train", "--verbose", "3", "--out", str(tmp_path)])
    assert "--verbose" in capsys.readouterr().err
