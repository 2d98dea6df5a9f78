"""The bench estimate of the reference deviation (``agents.deviation_estimator``): its numpy run-time network is the
torch network it was trained as, the composed controller reads only the bench's observations and is repeatable, and
a policy without the deviation input is refused."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from agents.deviation_estimator import DeviationEstimator
from agents.estimated_policy import EstimatedDeviationPolicy
from agents.heldout import nominal_benches, run_episode
from agents.robust_policy import DeviationPolicy, RobustPolicy
from experiments import deviation_estimator as E



def _act(x):
    """The stand-in PPO's fixed rule of the newest frame."""
    return np.array([0.4, 0.1 * np.tanh(1e3 * x[45])], dtype=np.float32)


@pytest.fixture(scope="module")
def trained(tmp_path_factory, recording_model):
    """An estimator trained for two epochs on three teacher episodes (the teacher: the stand-in, bound to the env)."""
    out = tmp_path_factory.mktemp("est")
    benches = nominal_benches((30.0, 40.0, 50.0))
    for k, bench in enumerate(benches):
        recorder = recording_model(_act)
        arrays = E.rollout(DeviationPolicy(recorder, recorder), bench, seed=k)
        (out / "data" / "shards").mkdir(parents=True, exist_ok=True)
        E._save(out / "data" / "shards" / f"{k:07d}.npz", draw=k, **arrays)
    args = argparse.Namespace(data=[out / "data"], policy="/no/run", out=out / "est", gru=8, hidden=6, epochs=2,
                              batch=2, lr=1e-2, seed=0, outlier_mm=np.inf)
    spec = E.train(args)
    return out, spec


def test_the_numpy_estimator_is_the_torch_network_it_was_trained_as(trained):
    import torch
    from safetensors.numpy import load_file
    out, spec = trained
    tensors = load_file(str(out / "est" / "estimator.safetensors"))
    net = E.build_network(len(spec["targets"]), 8, 6, seed=1)
    net.load_state_dict({(k + "_l0" if k.startswith("gru.") else k): torch.from_numpy(v) for k, v in tensors.items()
                         if k.split(".")[0] in ("gru", "hidden", "head")})
    episode = E.load_shards([out / "data"])[1]
    x = (episode["obs"] - tensors["in_mean"]) / tensors["in_std"]
    with torch.no_grad():
        expected = net(torch.from_numpy(x[None].astype(np.float32)))[0].numpy() * tensors["out_std"] + tensors["out_mean"]
    estimator = DeviationEstimator.load(out / "est")
    estimator.reset()
    got = np.array([estimator.update(obs) for obs in episode["obs"]])
    assert len(got) > 5
    np.testing.assert_allclose(got[:, spec["targets"]], expected, rtol=1e-4, atol=1e-5)
    assert spec["fixed"] == {"0": 0.0, "6": 1.0}   # CP1's x deviation and slope: constants by construction
    np.testing.assert_array_equal(got[:, 0], 0.0)
    np.testing.assert_array_equal(got[:, 6], 1.0)


def test_the_composed_controller_feeds_its_estimate_reads_no_env_and_repeats(trained, recording_model):
    out, _ = trained
    bench = nominal_benches((40.0,))[0]
    runs = []
    for _ in range(2):
        recorder = recording_model(_act)
        composed = EstimatedDeviationPolicy(DeviationPolicy(recorder, recorder), DeviationEstimator.load(out / "est"))
        assert composed.needs_env is False   # play() never hands it the env
        run_episode(composed, bench, seed=3)
        runs.append(np.array(recorder.inputs))
    np.testing.assert_array_equal(runs[0], runs[1])
    estimator = DeviationEstimator.load(out / "est")   # the appended input is the estimator's, decision by decision
    frames = runs[0][:, 45:60]
    np.testing.assert_array_equal(runs[0][:, 60:], np.array([estimator.update(f) for f in frames], dtype=np.float32))
    assert np.ptp(runs[0][:, 61]) > 0   # the estimate moved along the episode


def test_a_policy_trained_without_the_deviation_input_is_refused(trained, recording_model):
    out, _ = trained
    recorder = recording_model(_act)
    with pytest.raises(ValueError, match="not a reference_deviation run"):
        EstimatedDeviationPolicy(RobustPolicy(recorder, recorder), DeviationEstimator.load(out / "est"))


LOOP_ENV = {"observation_mode": "bench", "randomize": True, "frame_stack": 4, "reference_deviation": True}


def _fed(estimator, obs, with_state):
    """What the in-loop batch appends after ``obs``: the estimate, and the GRU's state after it if asked."""
    estimate = estimator.update(obs).astype(np.float32)
    return np.concatenate([estimate, estimator.state]) if with_state else estimate


@pytest.mark.parametrize("with_state", [False, True])
def test_in_the_loop_each_row_is_fed_its_estimator_over_its_own_observations_once_across_episode_ends(trained,
                                                                                                    with_state):
    from agents import train_config
    folder = str(trained[0] / "est")
    env = train_config.make_vec_env({"env_id": train_config.V1, "n_envs": 2, "env": {
        **LOOP_ENV, "reference_deviation_estimator": folder, "reference_deviation_estimator_state": with_state}}, seed=3)
    assert env.observation_space.shape == (60 + 12 + 8 * with_state,)   # the test estimator has 8 cells
    mine = [DeviationEstimator.load(folder) for _ in range(2)]   # the run-time estimator, fed here by hand
    obs, ends = env.reset(), 0
    expected = np.array([_fed(m, o[45:60], with_state) for m, o in zip(mine, obs)])
    for _ in range(400):
        np.testing.assert_array_equal(obs[:, 60:], expected)
        obs, _, done, infos = env.step(np.array([[0.3, -0.5], [0.6, 0.2]]))
        for i in range(2):
            if done[i]:   # the terminal observation's estimate, then a fresh state for the next episode's first
                terminal = infos[i]["terminal_observation"]
                np.testing.assert_array_equal(terminal[60:], _fed(mine[i], terminal[45:60], with_state))
                mine[i].reset()
                ends += 1
            expected[i] = _fed(mine[i], obs[i, 45:60], with_state)
        if ends >= 3:
            return
    pytest.fail(f"{ends} episodes ended in 400 periods")


@pytest.mark.parametrize("extra, message", [
    ({"reference_deviation_estimator": "/no/such/folder"}, "reference_deviation_estimator: expected an estimator folder"),
    ({"reference_deviation_bias_mm": 0.1}, "reference_deviation_estimator: .*and no reference_deviation_bias_mm"),
    ({"reference_deviation_estimator_state": 1}, "reference_deviation_estimator_state: expected true or false"),
    ({"reference_deviation_estimator": None, "reference_deviation_estimator_state": True}, "_state: .*true only with")])
def test_a_bad_estimator_in_the_loop_is_refused_by_name(trained, extra, message):
    from agents import train_config
    env = {**LOOP_ENV, "reference_deviation_estimator": str(trained[0] / "est"), **extra}
    with pytest.raises(ValueError, match=message):
        train_config.make_vec_env({"env_id": train_config.V1, "n_envs": 1, "env": env}, seed=0)


def test_a_run_trained_in_the_loop_drives_on_the_estimator_it_was_trained_with(trained, tmp_path, monkeypatch,
                                                                               recording_model):
    import json

    from agents import estimated_policy as D
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"env": {**LOOP_ENV, "reference_deviation_estimator_state": True,
                                                         "reference_deviation_estimator": str(trained[0] / "est")}}))
    recorder = recording_model(_act)
    loaded = []
    monkeypatch.setattr(D, "load_policy", lambda folder: loaded.append(folder) or DeviationPolicy(recorder, recorder))
    composed = D.EstimatedDeviationPolicy.load(run)
    assert loaded == [str(run)] and composed.policy_run == str(run)   # not the run the estimator's spec names
    assert composed.estimator.spec["weights_sha256"] == DeviationEstimator.load(trained[0] / "est").spec["weights_sha256"]
    obs = E.load_shards([trained[0] / "data"])[0]["obs"][5]   # a bench observation the estimator was fitted on
    composed.reset(40e3, None)
    composed.act(obs)   # the run trained on the GRU's state reads it after the estimate
    np.testing.assert_array_equal(recorder.inputs[-1][60:72], composed.estimate.astype(np.float32))
    np.testing.assert_array_equal(recorder.inputs[-1][72:], composed.estimator.state)
    assert len(recorder.inputs[-1]) == 80 and np.ptp(composed.estimator.state) > 0


def test_seed_loop_makes_a_checkpoint_of_the_exact_run_that_train_continues_with_the_estimator(trained, tmp_path):
    import json

    from stable_baselines3.common.vec_env import VecNormalize

    from agents import train_config
    from agents.checkpoint_files import read_normalizer
    from agents.trainer import _refuse_another_configuration
    run, folder = tmp_path / "exact", str(trained[0] / "est")
    run.mkdir()
    config = {"env_id": train_config.V1, "n_envs": 1, "env": LOOP_ENV, "train": {"total_timesteps": 4096}}
    normalizer = VecNormalize(train_config.make_vec_env(config, seed=0))
    normalizer.obs_rms.mean[:] = np.arange(72.0)   # statistics the copy must carry
    normalizer.save(str(run / "vecnormalize.pkl"))
    (run / "final_model.zip").write_bytes(b"the model's bytes")
    (run / "config.json").write_text(json.dumps(config))
    (run / "done.json").write_text(json.dumps({"timesteps": 4096}))
    (run / "learning_curve.csv").write_text("timesteps,wall_s,score\n16,0.5,7.5\n4096,9.0,1.25\n")
    out = tmp_path / "loop" / "seed_0"
    E.seed_loop(str(run), folder, out)
    state = json.loads((out / "checkpoint" / "state.json").read_text())
    assert state["timesteps"] == 4096
    assert state["curve"][-1] == {"timesteps": 4096, "wall_s": 9.0, "score": 1.25}   # the next evaluation is later
    assert (out / "checkpoint" / state["model"]).read_bytes() == b"the model's bytes"
    stats = read_normalizer(out / "checkpoint" / state["vecnormalize"])
    np.testing.assert_array_equal(stats["obs_mean"], np.arange(72.0))
    assert int(stats["timesteps"]) == 4096
    loop = {**config, "env": {**LOOP_ENV, "reference_deviation_estimator": folder}}
    _refuse_another_configuration(out, loop)   # the in-loop command continues it ...
    with pytest.raises(ValueError, match="another env"):
        _refuse_another_configuration(out, config)   # ... the exact one does not
    with pytest.raises(ValueError, match="holds a run already"):
        E.seed_loop(str(run), folder, out)
    with pytest.raises(ValueError, match="--tracker needs --bank"):
        E.seed_loop(str(run), folder, tmp_path / "loop" / "seed_1", tracker=True)
    tracked = E.seed_loop(str(run), None, tmp_path / "loop" / "seed_2", bank=16, tracker=True)
    assert tracked["tracker"] and json.loads((tmp_path / "loop" / "seed_2" / "config.json").read_text())["env"][
        "reference_deviation_tracker"] is True
