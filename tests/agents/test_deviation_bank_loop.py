"""The specimen bank in the PPO training loop (``env: reference_deviation_bank: N``, :mod:`agents.deviation_bank`;
with ``reference_deviation_tracker: true``, the bank's Gauss-Newton tracker, :mod:`agents.deviation_tracker`): each
training row is fed the estimate ``banked:RUN`` computes at the bench (a bank of N hypotheses reset at each
episode's start, weighed by each observation, advanced by the command the row ran), not the truth; ``banked:RUN``
runs a bank-trained run on the bank size (and tracker) it was trained with; bad settings are refused by name."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents import train_config
from agents.deviation_tracker import deviation_estimator

LOOP_ENV = {"observation_mode": "bench", "randomize": True, "frame_stack": 4, "reference_deviation": True}
ACTIONS = np.array([[0.3, -0.5], [0.6, 0.2]])


@pytest.mark.parametrize("tracker", [False, True])
def test_each_training_row_is_fed_its_own_banks_estimate_reset_at_each_episode_start(tracker):
    env = train_config.make_vec_env({"env_id": train_config.V1, "n_envs": 2, "env": {
        **LOOP_ENV, "reference_deviation_bank": 3, "reference_deviation_tracker": tracker}}, seed=3)
    assert env.observation_space.shape == (60 + 12,)
    batch = env.batch
    mine = [deviation_estimator(3, tracker) for _ in range(2)]   # banked:RUN's estimate, fed here by hand

    def fresh(i: int, obs: np.ndarray) -> np.ndarray:
        mine[i].reset(batch.benches[i].load_N, batch.config)
        return mine[i].estimate(obs[45:60]).astype(np.float32)

    obs, ends, off_truth = env.reset(), 0, 0.0
    expected = np.array([fresh(i, o) for i, o in enumerate(obs)])
    for _ in range(400):
        np.testing.assert_array_equal(obs[:, 60:], expected)
        off_truth = max(off_truth, float(np.abs(obs[:, 60:66] - batch.reference_deviations()[:, :6]).max()))
        obs, _, done, infos = env.step(ACTIONS)
        for i in range(2):
            mine[i].advance(ACTIONS[i])
            if done[i]:   # the terminal observation's estimate, then a new bank for the next episode's first
                terminal = infos[i]["terminal_observation"]
                np.testing.assert_array_equal(terminal[60:], mine[i].estimate(terminal[45:60]).astype(np.float32))
                expected[i] = fresh(i, obs[i])
                ends += 1
            else:
                expected[i] = mine[i].estimate(obs[i, 45:60]).astype(np.float32)
        if ends >= 3:
            assert off_truth > 1e-4   # the bank's estimate, not the true deviation (which is not a hypothesis)
            assert not tracker or sum(m.counts["refits"] for m in mine) > 0   # (the tracker ran, not just its bank)
            return
    pytest.fail(f"{ends} episodes ended in 400 periods")


@pytest.mark.parametrize("extra, message", [
    ({"reference_deviation_bank": 0}, "reference_deviation_bank: expected a number of hypotheses"),
    ({"reference_deviation_bank": True}, "reference_deviation_bank: expected a number of hypotheses"),
    ({"reference_deviation_bank": 4, "reference_deviation_bias_mm": 0.1}, "reference_deviation_bank: needs"),
    ({"reference_deviation_bank": 4, "reference_deviation": False}, "reference_deviation_bank: needs"),
    ({"reference_deviation_tracker": True}, "reference_deviation_tracker: expected true or false, and true only"),
    ({"reference_deviation_bank": 4, "reference_deviation_tracker": "yes"}, "reference_deviation_tracker")])
def test_a_bad_bank_in_the_loop_is_refused_by_name(extra, message):
    with pytest.raises(ValueError, match=message):
        train_config.make_vec_env({"env_id": train_config.V1, "n_envs": 1, "env": {**LOOP_ENV, **extra}}, seed=0)


def test_banked_runs_a_bank_trained_run_on_the_bank_size_it_was_trained_with(tmp_path, monkeypatch, recording_model):
    import json

    from agents import banked_deviation as B
    from agents.robust_policy import DeviationPolicy
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"env": {**LOOP_ENV, "reference_deviation_bank": 5}}))
    recorder = recording_model(lambda x: np.zeros(2, np.float32))
    monkeypatch.setattr(B, "load_policy", lambda folder: DeviationPolicy(recorder, recorder))
    assert B.BankedDeviationPolicy.load(run).bank_settings.bank_size == 5
    with pytest.raises(ValueError, match="trained on a bank of 5"):
        B.BankedDeviationPolicy.load(run, bank_size=16)
    (run / "config.json").write_text(json.dumps({"env": LOOP_ENV}))   # a run trained on the truth: the default
    assert B.BankedDeviationPolicy.load(run).bank_settings.bank_size == B.BANK_SIZE
    (run / "config.json").write_text(json.dumps({"env": {**LOOP_ENV, "reference_deviation_bank": 5,
                                                         "reference_deviation_tracker": True}}))
    tracked = B.BankedDeviationPolicy.load(run)   # a tracker-trained run drives on its tracker, behind the decision
    worker = tracked.deviation_bank
    assert type(worker).__name__ == "EstimateWorker" and type(worker.deviation_bank).__name__ == "GaussNewtonTracker"
    assert worker.deviation_bank.deviation_bank.settings.bank_size == 5
    from experiments.shipping import bank_of
    assert bank_of([run]) == {"bank_size": 5, "tracker": True}   # shipped with its tracker behind the decision
