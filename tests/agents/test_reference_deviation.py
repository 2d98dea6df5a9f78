"""The reference-deviation input (``env: reference_deviation: true``, :func:`envs.core.reference_deviation`): each
contact point's x and z deviation from the episode's true hydrostatic reference, whose norms are the env's own
``distance_mm``, and the reference's slope; the training batch and the bound controller read the same values."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents import train_config
from agents.heldout import nominal_benches, run_episode
from agents.robust_policy import DeviationPolicy
from envs import core as S
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

ENV = {"observation_mode": "bench", "randomize": True, "frame_stack": 4}
PLAIN = 4 * 15
ACTIONS = np.array([[0.3, -0.5], [0.6, 0.2]])


def _distance_mm(deviation: np.ndarray) -> float:
    """The step's distance from the deviation part: the mean over the three points of each (x, z) norm."""
    pairs = deviation[:6].reshape(3, 2)
    return float(np.hypot(pairs[:, 0], pairs[:, 1]).sum() / 3.0)


def test_the_deviations_norms_are_the_envs_own_distance_at_every_step():
    env = TriPlanarShearV1Env()
    env.reset(seed=0, options={"bench": nominal_benches((40.0,))[0]})
    distances = []
    for step in range(60):
        _, _, terminated, truncated, info = env.step(ACTIONS[step % 2])
        np.testing.assert_allclose(_distance_mm(env.reference_deviation()), info["distance_mm"], rtol=1e-12)
        distances.append(info["distance_mm"])
        if terminated or truncated:
            break
    assert max(distances) > 0.1   # the block left its reference: the check above compared non-trivial numbers


def test_a_hand_checked_deviation_and_slope():
    travel = 0.08
    grid = np.linspace(0.0, travel, S.REFERENCE_POINTS)
    ref = np.zeros((S.REFERENCE_POINTS, 9))
    ref[:, 0], ref[:, 2], ref[:, 5] = grid, -0.5 * grid, 0.25 * grid ** 2 / travel   # CP1 x, CP1 z, CP2 z
    obs = np.zeros(S.OBS_DIM)
    s = 0.0301   # between samples 60 (0.030 m) and 61 (0.0305 m)
    obs[S.OBS_POS + 0], obs[S.OBS_POS + 2], obs[S.OBS_POS + 5] = s, -0.5 * s + 0.002, 0.001
    obs[S.OBS_REF + 0], obs[S.OBS_REF + 2], obs[S.OBS_REF + 5] = s, -0.5 * s, 0.0025
    got = S.reference_deviation(obs, ref, travel)
    np.testing.assert_allclose(got[:6], [0.0, 2.0, 0.0, -1.5, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(got[6:], [1.0, -0.5, 0.0, 0.25 * (0.030 + 0.0305) / travel, 0.0, 0.0], atol=1e-12)


def _vec_env(**extra):
    return train_config.make_vec_env({"env_id": train_config.V1, "n_envs": 2, "env": {**ENV, **extra}}, seed=3)


def test_the_batch_appends_each_rows_deviation_as_the_single_env_computes_it():
    plain, dev = _vec_env(), _vec_env(reference_deviation=True)
    assert dev.observation_space.shape == (PLAIN + 12,)
    obs_plain, obs_dev = plain.reset(), dev.reset()
    singles = [TriPlanarShearV1Env(**{k: v for k, v in ENV.items() if k != "frame_stack"}) for _ in range(2)]
    for i, env in enumerate(singles):
        env.reset(seed=3 + i)
    for step in range(30):
        np.testing.assert_array_equal(obs_dev[:, :PLAIN], obs_plain)
        for i, env in enumerate(singles):
            np.testing.assert_array_equal(obs_dev[i, PLAIN:], env.reference_deviation().astype(np.float32))
        obs_plain, _, _, _ = plain.step(ACTIONS)
        obs_dev, _, done, _ = dev.step(ACTIONS)
        for i, env in enumerate(singles):
            env.step(ACTIONS[i])
        if done.any():   # (an autoreset row draws from the batch's stream: compared up to here)
            assert step > 3
            return



def test_the_deviation_policy_feeds_the_bound_envs_deviation_and_refuses_unbound(recording_model):
    recorder = recording_model()
    with pytest.raises(RuntimeError, match="bind"):
        DeviationPolicy(recorder, recorder).act(np.zeros(15, dtype=np.float32))
    seen = []
    run_episode(DeviationPolicy(recorder, recorder), nominal_benches((40.0,))[0], seed=0,
                on_step=lambda info: seen.append(info["distance_mm"]))
    assert len(recorder.inputs) == len(seen) > 1
    for before, distance in zip(recorder.inputs[1:], seen):   # decision k+1 reads the state step k left
        assert _distance_mm(before[PLAIN:]) == pytest.approx(distance, rel=1e-5)


def test_both_privileged_inputs_at_once_are_refused_by_name():
    with pytest.raises(ValueError, match="privileged and reference_deviation"):
        train_config.load_config(train_config.PROFILES[train_config.V1].configs["ppo"],
                                 {"env.privileged": True, "env.reference_deviation": True}, train_config.V1)
    with pytest.raises(ValueError, match="reference_deviation: expected true or false"):
        train_config.load_config(train_config.PROFILES[train_config.V1].configs["ppo"],
                                 {"env.reference_deviation": 1}, train_config.V1)
    config = {"env": {**ENV, "reference_deviation": True}}
    assert train_config.extra_input_of(config) == "reference_deviation"
    assert "reference_deviation" not in train_config.single_env_kwargs(config)


def test_a_training_bias_is_constant_within_an_episode_redrawn_at_the_next_and_only_on_the_estimated_values():
    exact, biased = _vec_env(reference_deviation=True), _vec_env(reference_deviation=True,
                                                                 reference_deviation_bias_mm=0.2)
    obs_exact, obs_biased = exact.reset(), biased.reset()
    first = (obs_biased - obs_exact)[:, PLAIN:]
    for step in range(400):
        diff = (obs_biased - obs_exact)[:, PLAIN:]
        np.testing.assert_array_equal(diff[:, [0] + list(range(6, 12))], 0.0)   # CP1 x and the slope: exact
        assert np.all(np.abs(diff[:, 1:6]) > 1e-5)
        np.testing.assert_allclose(diff, first, atol=1e-5)
        obs_exact, _, done, infos_exact = exact.step(ACTIONS)
        obs_biased, _, done_b, infos = biased.step(ACTIONS)
        np.testing.assert_array_equal(done, done_b)
        if done.any():   # the ended episode keeps its bias to its terminal observation; the next gets a new one
            i = int(np.flatnonzero(done)[0])
            ended = infos[i]["terminal_observation"] - infos_exact[i]["terminal_observation"]
            np.testing.assert_allclose(ended[PLAIN:], first[i], atol=1e-5)
            assert np.all(np.abs((obs_biased - obs_exact)[i, PLAIN + 1:PLAIN + 6] - first[i, 1:6]) > 1e-4)
            return
    pytest.fail("no episode ended in 400 periods")


@pytest.mark.parametrize("overrides, message", [
    ({"env.reference_deviation_bias_mm": 0.1}, "needs reference_deviation: true"),
    ({"env.reference_deviation": True, "env.reference_deviation_bias_mm": -1}, "expected a number of mm >= 0")])
def test_a_bad_training_bias_is_refused_by_name(overrides, message):
    with pytest.raises(ValueError, match=f"reference_deviation_bias_mm: .*{message}"):
        train_config.load_config(train_config.PROFILES[train_config.V1].configs["ppo"], overrides, train_config.V1)
