"""Controllers, the evaluation function, PPO training (smoke) and the study pipeline."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents import LowFrictionTip, MomentMatching, SteelTip, TrackingTip, evaluate
from agents.train_ppo import DEFAULT_CONFIG, load_config, train_ppo


@pytest.fixture(scope="module")
def steel_27() -> float:
    result = evaluate(SteelTip(), 27.8)
    assert result.success and result.reason == "travel"
    return result.mimicry_error_mm


@pytest.mark.parametrize("controller", [LowFrictionTip(phi_deg=3.0), TrackingTip(), MomentMatching()],
                         ids=lambda c: c.name)
def test_scripted_controllers_beat_the_steel_tip(controller, steel_27: float) -> None:
    result = evaluate(controller, 27.8)
    assert result.success
    assert result.mimicry_error_mm < 0.8 * steel_27


def test_evaluation_result_is_consistent() -> None:
    result = evaluate(LowFrictionTip(phi_deg=3.0), 40.0)
    assert result.steps == len(result.actions) == len(result.contact_points) - 1
    assert result.contact_points.shape[1:] == (3, 3) and result.reference.shape == (161, 3, 3)
    travel = result.contact_points[-1, 0, 0] - result.reference[0, 0, 0]
    assert travel == pytest.approx(0.08, abs=1e-12) and result.travel_m == pytest.approx(0.08, abs=1e-12)
    # the teflon tip really ran with a 3-degree tip: it differs from the steel tip
    assert result.mimicry_error_mm != pytest.approx(evaluate(SteelTip(), 40.0).mimicry_error_mm)
    assert np.all(result.actions == result.actions[0])  # constant commands


def tiny_config() -> dict:
    config = load_config(DEFAULT_CONFIG, {"n_envs": 4, "ppo.n_steps": 128, "ppo.batch_size": 128, "ppo.n_epochs": 2,
                                          "train.eval_freq": 1024, "train.checkpoint_freq": 1024})
    config["eval_loads"] = [27.8, 55.6]
    return config


@pytest.mark.slow
def test_ppo_smoke_trains_saves_resumes_loads_and_evaluates(tmp_path) -> None:
    from agents.ppo_controller import PPOController
    config = tiny_config()
    first = train_ppo(config, tmp_path, seed=1, total_timesteps=2048)
    run = tmp_path / "seed_1"
    assert first.timesteps == 2048 and first.model_path.exists() and first.vecnormalize_path.exists()
    assert sorted(p.name for p in (run / "checkpoints").glob("*.zip")) == ["ppo_1024_steps.zip", "ppo_2048_steps.zip"]
    assert any((run / "tb").rglob("events.out.tfevents*")) and (run / "eval" / "evaluations.npz").exists()
    rows = first.curve_path.read_text().splitlines()
    assert rows[0].startswith("timesteps,wall_s,error_mm_27.8N,error_mm_55.6N") and len(rows) == 3
    assert json.loads((run / "done.json").read_text())["timesteps"] == 2048
    again = train_ppo(config, tmp_path, seed=1, total_timesteps=2048)  # finished: returned as it is
    assert again.timesteps == 2048 and len(again.curve_path.read_text().splitlines()) == 3
    resumed = train_ppo(config, tmp_path, seed=1, total_timesteps=3072)  # continues from the 2048 checkpoint
    assert resumed.timesteps == 3072 and len(resumed.curve_path.read_text().splitlines()) == 4
    controller = PPOController.load(resumed.model_path, resumed.vecnormalize_path)
    result = evaluate(controller, 27.8)
    assert np.isfinite(result.mimicry_error_mm) and result.steps > 0
    assert np.all(np.abs(result.actions) <= 1.0)


@pytest.mark.slow
def test_study_pipeline_writes_its_outputs(tmp_path) -> None:
    from experiments.study import run_study
    config = tiny_config()
    config_path = tmp_path / "ppo.yaml"
    import yaml
    config_path.write_text(yaml.safe_dump(config))
    result = run_study(tmp_path / "out", ppo_dir=tmp_path / "runs", seeds=(0,), config=config_path,
                       timesteps=1024, loads=(27.8, 55.6), doc=tmp_path / "study.md", log=lambda _: None)
    out = tmp_path / "out"
    for name in ("episodes.csv", "mimicry_table.csv", "summary.json", "errors_by_load.png", "learning_curves.png",
                 "actions_27.8N.png", "traces_steel_tip.png", "traces_ppo.png"):
        assert (out / name).exists(), name
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["controllers"]) == {"steel tip", "teflon tip", "tracking tip", "moment matching",
                                           "frictionless tip", "PPO"}
    assert summary["scripted"] == ["steel tip", "teflon tip", "tracking tip", "moment matching"]
    assert len(result.episodes) == 6 * 2
    text = (tmp_path / "study.md").read_text()
    assert "| 27.8 |" in text and "Conclusions" in text


def test_a_failed_episode_has_no_mimicry_error() -> None:
    import math

    from agents.controllers import SteelTip

    class NoThrust(SteelTip):
        def act(self, obs):
            return np.array([-1.0, 0.0], dtype=np.float32)

    failed = evaluate(NoThrust(name="no thrust"), 30.3)
    assert not failed.success and math.isnan(failed.mimicry_error_mm)
    assert math.isfinite(failed.mimicry_error_reached_mm)


def test_run_episode_hands_every_steps_info_to_on_step() -> None:
    """The per-step infos a run reports (``benchmarks/bench_mpc.py``'s travel profile) are the episode's own: one per
    step, the travel never falling, and the last one carrying the outcome's mimicry error."""
    from agents.bench_controllers import make_controller
    from agents.heldout import nominal_benches, run_episode
    infos: list[dict] = []
    outcome = run_episode(make_controller("frictionless_tip"), nominal_benches((40.0,))[0], seed=0,
                          on_step=infos.append)
    assert len(infos) == outcome.steps > 1
    travel = [i["travel_m"] for i in infos]
    assert np.all(np.diff(travel) >= 0.0) and travel[-1] == pytest.approx(outcome.travel_m)
    assert infos[-1]["mimicry_error_mm"] == pytest.approx(outcome.mimicry_error_mm)
