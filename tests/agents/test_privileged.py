"""The privileged teacher's inputs (``env: privileged: true``, :mod:`agents.privileged`): the training env appends each
row's true unknowns, scaled over the training ranges, to the plain observation; the controller reads them from the
env it is bound to and refuses to act without it."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents import train_config
from agents.heldout import nominal_benches, run_episode
from agents.privileged import TRUTH_NAMES, bench_truth, privileged_row, truth_scale
from agents.robust_policy import PrivilegedPolicy
from envs.triplanar_shear_v1 import TRAINING_RANGES, TriPlanarShearV1Env

ENV = {"observation_mode": "bench", "randomize": True, "frame_stack": 4}
PLAIN = 4 * 15


def _vec_env(privileged: bool):
    config = {"env_id": train_config.V1, "n_envs": 2, "env": {**ENV, "privileged": privileged}}
    return train_config.make_vec_env(config, seed=3)


def _expected_row(bench) -> np.ndarray:
    """The row written out from the ranges for the entries whose range is plain (tip friction, load level)."""
    truth = dict(zip(TRUTH_NAMES, bench_truth(bench)))
    (tip_lo, tip_hi), (load_lo, load_hi) = TRAINING_RANGES.tip_friction_deg, TRAINING_RANGES.load_N
    return np.array([(truth["tip_friction_deg"] - (tip_lo + tip_hi) / 2) / ((tip_hi - tip_lo) / 2),
                     (truth["load_N"] - (load_lo + load_hi) / 2) / ((load_hi - load_lo) / 2)])


def test_the_privileged_observation_is_the_plain_one_then_the_scaled_truth_of_each_rows_bench():
    plain, priv = _vec_env(False), _vec_env(True)
    assert priv.observation_space.shape == (PLAIN + len(TRUTH_NAMES),)
    obs_plain, obs_priv = plain.reset(), priv.reset()
    scale = truth_scale(priv.batch.specimen, priv.batch.foundation)
    for step in range(400):
        benches = list(priv.batch.benches)
        np.testing.assert_array_equal(obs_priv[:, :PLAIN], obs_plain)
        for i, bench in enumerate(benches):
            np.testing.assert_array_equal(obs_priv[i, PLAIN:], privileged_row(bench, scale))
            np.testing.assert_allclose(obs_priv[i, PLAIN:][[0, -1]], _expected_row(bench), rtol=1e-6)
        actions = np.tile([0.3, -0.5], (2, 1))
        obs_plain, _, done_plain, _ = plain.step(actions)
        obs_priv, _, done, infos = priv.step(actions)
        np.testing.assert_array_equal(done, done_plain)
        if done.any():   # the ended episode's row in its terminal observation, the next episode's after it
            i = int(np.flatnonzero(done)[0])
            np.testing.assert_array_equal(infos[i]["terminal_observation"][PLAIN:], privileged_row(benches[i], scale))
            assert priv.batch.benches[i] is not benches[i]
            np.testing.assert_array_equal(obs_priv[i, PLAIN:], privileged_row(priv.batch.benches[i], scale))
            return
    pytest.fail("no episode ended in 400 periods")



def test_the_privileged_policy_feeds_the_frame_stack_then_the_bound_envs_truth(recording_model):
    recorder = recording_model()
    policy = PrivilegedPolicy(recorder, recorder)
    bench = nominal_benches((40.0,))[0]
    outcome = run_episode(policy, bench, seed=0)
    assert outcome.steps == len(recorder.inputs) > 0
    env = TriPlanarShearV1Env()
    first, _ = env.reset(seed=0, options={"bench": bench})
    row = privileged_row(bench, truth_scale(*env.config.base_specimen()))
    np.testing.assert_array_equal(recorder.inputs[0], np.concatenate([np.tile(first, 4), row]))
    np.testing.assert_array_equal(recorder.inputs[-1][PLAIN:], row)


def test_the_privileged_policy_refuses_to_act_unbound(recording_model):
    recorder = recording_model()
    policy = PrivilegedPolicy(recorder, recorder)
    policy.reset(40.0, TriPlanarShearV1Env().config)
    with pytest.raises(RuntimeError, match="bind"):
        policy.act(np.zeros(15, dtype=np.float32))
    assert not recorder.inputs


@pytest.mark.parametrize("overrides, message", [({"env.privileged": "yes"}, "privileged: expected true or false"),
                                                 ({"env.privileged": True, "algo": "recurrent",
                                                   "policy": "MlpLstmPolicy"}, "privileged: .*algo ppo")])
def test_a_bad_privileged_option_is_refused_by_name(overrides, message):
    with pytest.raises(ValueError, match=message):
        train_config.load_config(train_config.PROFILES[train_config.V1].configs["ppo"], overrides, train_config.V1)


def test_the_evaluation_episodes_run_the_env_without_the_option():
    config = {"env": {**ENV, "privileged": True}}
    assert train_config.extra_input_of(config) == "privileged"
    assert "privileged" not in train_config.single_env_kwargs(config)
