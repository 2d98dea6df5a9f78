"""The specimen bank's estimate of the reference deviation (``SpecimenBank.deviations``, ``agents.banked_deviation``):
each hypothesis's deviation is what the env computes for a bench that is that hypothesis, through resample-moves;
the bank's update split around the decision (predict, then weigh) weighs each by its own predictions; the composed
controller feeds the bank's estimate to the policy, plays the start, reads no env and repeats."""

from __future__ import annotations

import numpy as np
import pytest

from agents.banked_deviation import BankedDeviationPolicy
from agents.estimator import bench_of
from agents.heldout import nominal_benches, run_episode
from agents.mpc import MPCController
from agents.robust_policy import DeviationPolicy, RobustPolicy
from envs.core import OBS_POS
from envs.triplanar_shear_v1 import B_RANGE, TriPlanarShearV1Env


def _act(x):
    """The stand-in PPO's fixed rule of the newest frame."""
    return np.array([0.4, 0.1 * np.tanh(1e3 * x[45])], dtype=np.float32)


def _check_against_twins(bank, commands):
    """Each hypothesis's deviation is the env's for the bench it stands for, run with the same commands."""
    got = bank.deviations()
    for j, theta in enumerate(bank.theta):
        twin = TriPlanarShearV1Env(**bank.env_kwargs)
        twin.reset(seed=0, options={"bench": bench_of(bank.prior, theta, bank.load_N)})
        for raw in commands:
            twin.step(raw)
        # (1e-6 mm: the start's observation is the env's float32 one; a wrong hypothesis's is off by mm)
        np.testing.assert_allclose(got[j], twin.reference_deviation(), rtol=0, atol=1e-6)
    np.testing.assert_allclose(bank.deviation(), bank.weights() @ got, rtol=0, atol=1e-12)


def test_each_hypothesis_deviation_is_the_envs_for_that_bench_right_after_a_resample_move():
    bench = nominal_benches((40.0,))[0]
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=1, options={"bench": bench})
    bank = MPCController(bank_size=6, refine_every=0, move_periods=0).new_bank(bench.load_N, env.unwrapped.config)
    _check_against_twins(bank, [])
    commands, checked = [], 0
    for k in range(10):
        raw = np.array([0.3 + 0.05 * (k % 3), 0.05 * (-1) ** k])
        commands.append(raw)
        obs, *_ = env.step(raw.astype(np.float32))
        moves = bank.rejuvenations
        bank.update(raw, obs)
        if bank.rejuvenations > moves:   # the hypotheses were just replaced by moved ones
            _check_against_twins(bank, commands)
            checked += 1
    assert checked > 0


def test_each_hypothesis_is_weighed_by_its_own_predictions_through_moves_and_refinements():
    bench = nominal_benches((40.0,))[0]
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=2, options={"bench": bench})
    settings = MPCController(bank_size=6, refine_every=4, refine_evaluations=4, move_periods=0)
    bank = settings.new_bank(bench.load_N, env.unwrapped.config)
    for k in range(9):   # the update split around a decision, as banked:RUN runs it
        raw = np.array([0.3 + 0.05 * (k % 3), 0.05 * (-1) ** k])
        obs, *_ = env.step(raw.astype(np.float32))
        bank.predict(raw)
        bank.weigh(obs[B_RANGE:B_RANGE + 9])
    assert bank.rejuvenations > 0 and bank.refinements > 0 and bank.fallbacks == 0
    variance = bank.sensor_noise_m ** 2 + bank.model_error_m ** 2
    for j in np.flatnonzero(bank.alive):   # the whole history's likelihood of an env run as hypothesis j
        twin = TriPlanarShearV1Env(**bank.env_kwargs)
        twin.reset(seed=0, options={"bench": bench_of(bank.prior, bank.theta[j], bank.load_N)})
        ll = 0.0
        for raw, measured in bank.history:
            state_obs, *_ = twin.step(raw)
            r = state_obs[OBS_POS:OBS_POS + 9].astype(float) - measured
            ll += -0.5 * float(r @ r) / variance
        np.testing.assert_allclose(bank.ll[j], ll, rtol=1e-5)   # (the twin's observation is float32)
    with pytest.raises(RuntimeError, match="predict"):
        bank.weigh(obs[B_RANGE:B_RANGE + 9])


class _Recorded(BankedDeviationPolicy):
    """Records what it sees and the commands it sends."""

    def reset(self, load_N, config):
        super().reset(load_N, config)
        self.seen, self.sent = [], []

    def act(self, obs):
        action = super().act(obs)
        self.seen.append(np.array(obs))
        self.sent.append(np.array(action))
        return action


def test_the_composed_controller_feeds_the_banks_estimate_plays_the_start_and_repeats(recording_model):
    bench = nominal_benches((40.0,))[0]
    runs = []
    for _ in range(2):
        recorder = recording_model(_act)
        composed = _Recorded(DeviationPolicy(recorder, recorder), MPCController(bank_size=4), start_periods=2)
        assert composed.needs_env is False   # play() never hands it the env
        outcome = run_episode(composed, bench, seed=3)
        runs.append(np.array(recorder.inputs))
    np.testing.assert_array_equal(runs[0], runs[1])
    inputs, sent, settings = runs[0], composed.sent, composed.bank_settings
    config = TriPlanarShearV1Env().unwrapped.config
    np.testing.assert_array_equal(sent[:2], [settings.start_command(k, config).astype(np.float32) for k in (1, 2)])
    assert len(inputs) == outcome.steps - 2   # the policy decided every period after the start
    np.testing.assert_array_equal(inputs[:, 45:60], composed.seen[2:])
    bank = settings.new_bank(bench.load_N, config)   # the appended input is a bank's fed the same periods
    bank.rejuvenate_ess = 0.0
    for k, obs in enumerate(composed.seen):
        if k:
            bank.update(np.asarray(sent[k - 1], dtype=np.float64), obs)
        if k >= 2:
            np.testing.assert_array_equal(inputs[k - 2, 60:], bank.deviation(composed.min_ess).astype(np.float32))
    assert np.ptp(inputs[:, 62]) > 0   # the estimate moved along the episode


def test_a_policy_without_the_deviation_input_and_bad_settings_are_refused(recording_model):
    recorder = recording_model(_act)
    with pytest.raises(ValueError, match="not a reference_deviation run"):
        BankedDeviationPolicy(RobustPolicy(recorder, recorder), MPCController(bank_size=4))
    with pytest.raises(ValueError, match="min_ess"):
        BankedDeviationPolicy(DeviationPolicy(recorder, recorder), MPCController(bank_size=4), min_ess=0.5)
    with pytest.raises(ValueError, match="start_periods"):
        BankedDeviationPolicy(DeviationPolicy(recorder, recorder), MPCController(bank_size=4), start_periods=-1)


def _sb3_model(activation):
    """An untrained SB3 MlpPolicy of the deviation policy's input and action sizes, as a model holds it."""
    import gymnasium as gym
    from stable_baselines3.common.policies import ActorCriticPolicy
    obs_space = gym.spaces.Box(-np.inf, np.inf, (72,), np.float32)
    act_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    policy = ActorCriticPolicy(obs_space, act_space, lambda _: 0.0, net_arch=[16, 16], activation_fn=activation)
    with __import__("torch").no_grad():
        policy.action_net.bias.fill_(1.0)   # so that about half the actions are clipped
    return type("Model", (), {"policy": policy, "action_space": act_space})()


def test_the_numpy_actor_is_sb3s_deterministic_predict_and_refuses_a_layout_it_does_not_know():
    import torch.nn as nn

    from agents.banked_deviation import NumpyActor
    model = _sb3_model(nn.Tanh)
    actor = NumpyActor(model)
    x = np.random.default_rng(0).normal(size=(200, 72)).astype(np.float32) * 3
    expected = np.array([model.policy.predict(row, deterministic=True)[0] for row in x])
    got = np.array([actor(row) for row in x])
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-6)
    assert (got == 1.0).any()   # the clip to the action space was exercised
    with pytest.raises(ValueError, match="'ELU'"):
        NumpyActor(_sb3_model(nn.ELU))


def test_a_starter_controller_plays_the_start_and_the_bank_advances_by_its_commands(recording_model):
    # finding 16: another controller (there the shipped ppo_recurrent) for the first decisions, fed their observations
    class Starter:
        def reset(self, load_N, config):
            self.seen, self.load_N = [], load_N

        def act(self, obs):
            self.seen.append(np.array(obs))
            return np.array([0.3 + 0.01 * len(self.seen), -0.05], dtype=np.float64)
    bench = nominal_benches((40.0,))[0]
    recorder, starter = recording_model(_act), Starter()
    composed = _Recorded(DeviationPolicy(recorder, recorder), MPCController(bank_size=4), start_periods=3,
                         starter=starter)
    outcome = run_episode(composed, bench, seed=3)
    inputs, sent, settings = np.array(recorder.inputs), composed.sent, composed.bank_settings
    assert starter.load_N == 40.0 and len(starter.seen) == 3 and len(inputs) == outcome.steps - 3
    np.testing.assert_array_equal(starter.seen, composed.seen[:3])
    np.testing.assert_array_equal(sent[:3], [np.float32([0.3 + 0.01 * k, -0.05]) for k in (1, 2, 3)])
    bank = settings.new_bank(bench.load_N, TriPlanarShearV1Env().unwrapped.config)   # advanced by the starter's
    bank.rejuvenate_ess = 0.0
    for k, obs in enumerate(composed.seen[:6]):
        if k:
            bank.update(np.asarray(sent[k - 1], dtype=np.float64), obs)
        if k >= 3:
            np.testing.assert_array_equal(inputs[k - 3, 60:], bank.deviation(composed.min_ess).astype(np.float32))
