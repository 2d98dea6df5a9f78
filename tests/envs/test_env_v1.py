"""TriPlanarShear-v1: bench dynamics, observation modes, randomisation, conventions, held-out evaluation."""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401 (registers the environments)
from envs.triplanar_shear import TriPlanarShearEnv
from envs.triplanar_shear_v1 import (B_RANGE, B_STAGE, B_THRUST, BENCH_OBS_DIM, RANDOM_LOAD_N, RANDOM_MASS,
                                     RANDOM_MASS_CENTRE_M, RANDOM_TIP_FRICTION_DEG, TriPlanarShearV1Env)

IDEAL = dict(stage_bandwidth_hz=math.inf, thrust_bandwidth_hz=math.inf, latency_s=0.0, sensor_noise_m=0.0)


def make(**kwargs) -> TriPlanarShearV1Env:
    return TriPlanarShearV1Env(**{"load_N": 30.3, **kwargs})


def test_ideal_bench_in_state_mode_is_v0_bitwise():
    v0, v1 = TriPlanarShearEnv(load_N=30.3), make(observation_mode="state", **IDEAL)
    o0, _ = v0.reset(seed=1)
    o1, _ = v1.reset(seed=1)
    assert np.array_equal(o0, o1)
    rng = np.random.default_rng(0)
    for _ in range(60):
        a = rng.uniform(-1, 1, 2)
        r0, r1 = v0.step(a), v1.step(a)
        assert np.array_equal(r0[0], r1[0]) and r0[1] == r1[1] and r0[2:4] == r1[2:4]
        if r0[2] or r0[3]:
            break


def test_stage_step_response_is_first_order():
    f = 20.0
    env = make(**{**IDEAL, "stage_bandwidth_hz": f})
    env.reset(seed=0)
    # small, and to the side where the block keeps sliding on its planes; below the stage's speed limit
    tau, u_cmd = 1 / (2 * math.pi * f), -0.1 * env.config.offset_range_m
    for k in range(1, 8):
        _, _, term, trunc, info = env.step(np.array([0.0, -0.1]))
        assert not (term or trunc)
        assert info["tip_offset_m"] == pytest.approx(u_cmd * (1 - math.exp(-k * env.dt / tau)), rel=1e-9, abs=1e-12)


def test_thrust_step_response_is_first_order():
    f = 30.0
    env = make(**{**IDEAL, "thrust_bandwidth_hz": f})
    env.reset(seed=0)
    tau, load = 1 / (2 * math.pi * f), 30.3
    target = 1.5 * load   # action 0.5 with thrust_scale 2
    for k in range(1, 6):
        obs, _, _, _, info = env.step(np.array([0.5, 0.0]))
        expected = target + (load - target) * math.exp(-k * env.dt / tau)
        assert info["load_cell_N"] == pytest.approx(expected, rel=1e-12)
        assert obs[B_THRUST] == pytest.approx(expected, rel=1e-6)
        # the period's applied thrust is the response's mean: between the values at its start and end
        before = target + (load - target) * math.exp(-(k - 1) * env.dt / tau)
        assert before < info["thrust_N"] < expected


def test_latency_delays_commands_by_whole_periods():
    env = make(**{**IDEAL, "latency_s": 0.01})
    env.reset(seed=0)
    offsets = [env.step(np.array([0.0, 0.1]))[4]["tip_offset_m"] for _ in range(4)]
    assert offsets[0] == offsets[1] == 0.0
    assert offsets[2] == pytest.approx(0.1 * env.config.offset_range_m, rel=1e-12)
    with pytest.raises(ValueError, match="latency_s"):
        make(latency_s=0.003)


def test_bench_observation_is_measurements_with_seeded_noise():
    quiet, noisy = make(sensor_noise_m=0.0), make(sensor_noise_m=2e-4)
    assert quiet.observation_space.shape == (BENCH_OBS_DIM,) == (15,)
    assert make(observation_mode="state").observation_space.shape == (34,)
    quiet.reset(seed=3)
    noisy.reset(seed=3)
    diffs = []
    for _ in range(40):
        a = np.array([0.0, 0.0])
        oq, on = quiet.step(a)[0], noisy.step(a)[0]
        diffs.append(on[B_RANGE:B_RANGE + 9] - oq[B_RANGE:B_RANGE + 9])
        assert on[B_STAGE] == oq[B_STAGE]
    assert 1.5e-4 < np.std(diffs) < 2.5e-4
    again = make(sensor_noise_m=2e-4)
    first = again.reset(seed=3)[0]
    assert np.array_equal(first, noisy.reset(seed=3)[0])
    with pytest.raises(ValueError, match="observation_mode"):
        make(observation_mode="pixels")


def test_randomisation_is_seeded_and_within_its_ranges():
    env = TriPlanarShearV1Env(randomize=True)
    nominal = env.config.base_specimen()[0]
    infos = [env.reset(seed=s)[1] for s in range(25)]
    assert infos[7] == TriPlanarShearV1Env(randomize=True).reset(seed=7)[1]
    for info in infos:
        assert RANDOM_LOAD_N[0] <= info["load_N"] <= RANDOM_LOAD_N[1]
        assert RANDOM_TIP_FRICTION_DEG[0] <= info["tip_friction_deg"] <= RANDOM_TIP_FRICTION_DEG[1]
        assert abs(info["mass_kg"] / nominal.mass_kg - 1) <= RANDOM_MASS
        assert np.all(np.abs(np.subtract(info["mass_centre_m"], nominal.mass_centre_m)) <= RANDOM_MASS_CENTRE_M)
        assert np.all(np.abs(np.subtract(info["friction_deg"], nominal.friction_deg)) <= 2.0)
    assert len({info["load_N"] for info in infos}) == len(infos)
    fixed_tip = TriPlanarShearV1Env(randomize=True, tip_friction_deg=0.5).reset(seed=0)[1]
    assert fixed_tip["tip_friction_deg"] == 0.5


def test_conventions():
    env = gym.make("TriPlanarShear-v1")
    # the env truncates itself at time_limit_s; the registered limit (what tools read) is the same 399 steps
    assert env.spec.max_episode_steps == 399 == env.unwrapped.config.agent_steps
    assert env.unwrapped.dt == 0.005 and env.metadata["render_fps"] == 200
    _, reset_info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(env.action_space.sample())
    assert set(reset_info) == set(step_info)
    short = make(time_limit_s=0.05)   # 10 periods, the first in reset
    short.reset(seed=0)
    ends = [short.step(np.array([0.0, 0.0]))[3] for _ in range(9)]
    assert ends == [False] * 8 + [True]
    pickle.loads(pickle.dumps(env.unwrapped)).reset(seed=0)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["bench", "state"])
def test_checkers_pass_without_warnings(mode):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("TriPlanarShear-v1", observation_mode=mode, randomize=True).unwrapped,
                  skip_render_check=True)  # the human-mode check below: headless, it warns by design
        sb3_check_env(TriPlanarShearV1Env(observation_mode=mode, randomize=True))


def test_render_is_fast_and_human_without_display_warns_once(monkeypatch):
    env = make(render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(20):
        env.step(np.zeros(2))
    frame = env.render()
    assert frame.shape == (400, 400, 3) and frame.dtype == np.uint8 and frame.min() < 255
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    human = make(render_mode="human")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        human.reset(seed=0)
        human.step(np.zeros(2))
        human.render()
    assert len([w for w in caught if "display" in str(w.message)]) == 1


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ["TriPlanarShear-v0", "TriPlanarShear-v1"])
def test_recorded_video_lasts_as_long_as_the_episode(tmp_path, env_id):
    from gymnasium.wrappers import RecordVideo
    from moviepy import VideoFileClip
    env = RecordVideo(gym.make(env_id, render_mode="rgb_array", load_N=30.3), str(tmp_path),
                      episode_trigger=lambda e: True, disable_logger=True)
    _, info = env.reset(seed=0)
    start = info["time_s"]   # the first control period runs in reset, before the first frame
    frames = 1
    while True:
        _, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
        frames += 1
        if terminated or truncated:
            break
    duration = info["time_s"] - start   # the episode the agent saw
    fps = env.metadata["render_fps"]
    env.close()
    assert frames > 20 and abs(frames / fps - duration) <= 1.5 / fps   # one frame per control period
    (video,) = tmp_path.glob("*.mp4")
    clip = VideoFileClip(str(video))
    # plays in real time: to the reset's frame (one more than the steps) and moviepy's duration (to 0.01 s)
    assert clip.fps == fps and abs(clip.duration - duration) <= 1.5 / fps + 0.005
    clip.close()


@pytest.mark.slow
def test_record_video_works(tmp_path):
    from gymnasium.wrappers import RecordVideo
    env = RecordVideo(gym.make("TriPlanarShear-v1", render_mode="rgb_array", load_N=30.3), str(tmp_path),
                      episode_trigger=lambda e: True, disable_logger=True)
    env.reset(seed=0)
    for _ in range(30):
        env.step(np.zeros(2))
    env.close()
    assert list(tmp_path.glob("*.mp4"))


def test_evaluation_counts_failures():
    from agents.bench_controllers import BenchController
    from agents.heldout import FAILURE_SCORE_MM, nominal_benches, run_episode, summarise

    class NoThrust(BenchController):
        def act(self, obs):
            return np.array([-1.0, 0.0], dtype=np.float32)

    bench = nominal_benches([30.3])[0]
    failed = run_episode(NoThrust(name="no_thrust"), bench, env_kwargs=IDEAL)
    ok = run_episode(BenchController(name="steel"), bench, env_kwargs=IDEAL)
    assert not failed.success and math.isnan(failed.mimicry_error_mm) and failed.reason not in ("", "travel")
    assert ok.success and ok.mimicry_error_mm > 0
    s = summarise([failed, ok])
    assert s["success_rate"] == 0.5 and s["mimicry_error_mm"] == ok.mimicry_error_mm
    assert s["score"] == pytest.approx((ok.mimicry_error_mm + FAILURE_SCORE_MM) / 2)


def test_heldout_set_is_fixed_and_disjoint_from_tuning():
    from agents.heldout import TUNING_SEED, heldout_benches, random_benches
    a, b = heldout_benches(5), heldout_benches(5)
    assert [x.load_N for x in a] == [x.load_N for x in b]
    tuning = {x.load_N for x in random_benches(5, TUNING_SEED)}
    assert not tuning & {x.load_N for x in a}
