"""TriPlanarShear-v0, the single environment: API checks, determinism, reward, terminations, fidelity to the core."""

from __future__ import annotations

import pickle
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs
from envs import core as S
from envs.triplanar_shear import TriPlanarShearEnv
from triplanar import kernel as K
from triplanar import paper_model, simulate
from triplanar.outcome import Outcome
from triplanar.specimen import reference

ROOT = Path(__file__).resolve().parents[2]


def rollout(env: gym.Env, actions: np.ndarray, seed: int = 0) -> list:
    """(obs, reward, terminated, truncated, info) per step, resetting after an episode ends."""
    out = [env.reset(seed=seed)]
    for action in actions:
        step = env.step(action)
        out.append(step)
        if step[2] or step[3]:
            out.append(env.reset())
    return out


def run_constant(env: TriPlanarShearEnv, action, limit: int = 500, switch: tuple[int, list] | None = None):
    env.reset(seed=0)
    for k in range(limit):
        a = switch[1] if switch is not None and k >= switch[0] else action
        obs, reward, terminated, truncated, info = env.step(np.asarray(a, dtype=np.float32))
        if terminated or truncated:
            return terminated, truncated, info, k
    raise AssertionError("episode did not end")


def test_registered_and_made_by_id() -> None:
    env = gym.make("TriPlanarShear-v0", load_N=32.5)
    assert isinstance(env.unwrapped, TriPlanarShearEnv)
    assert env.unwrapped.config.load_N == 32.5
    assert envs.ENV_ID in gym.registry
    code = "import gymnasium as gym; e = gym.make('envs:TriPlanarShear-v0'); print(type(e.unwrapped).__name__)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert out.stdout.strip() == "TriPlanarShearEnv"


def test_compiled_env_code_is_dropped_when_the_kernel_changes(tmp_path) -> None:
    kernel_file = tmp_path / "kernel.py"
    kernel_file.write_text("x = 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    (cache / "triplanar_shear.control_step-1.py311.nbi").write_text("old")
    assert envs._drop_stale_compiled_code(cache, [kernel_file])             # no stamp yet: dropped
    assert not any(cache.glob("*.nbi")) and (cache / "kernel.sha256").exists()
    (cache / "triplanar_shear.control_step-1.py311.nbi").write_text("new")
    assert not envs._drop_stale_compiled_code(cache, [kernel_file])         # same kernel: kept
    assert any(cache.glob("*.nbi"))
    kernel_file.write_text("x = 2\n")
    assert envs._drop_stale_compiled_code(cache, [kernel_file])             # kernel changed: dropped
    assert not any(cache.glob("*.nbi"))


def _newer_version(warning: warnings.WarningMessage) -> bool:
    """Gymnasium's notice on making v0 now that v1 exists (its convention for an older version)."""
    return "is out of date" in str(warning.message)


def test_gymnasium_env_checker_has_no_warnings() -> None:
    from gymnasium.utils.env_checker import check_env
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(gym.make("TriPlanarShear-v0").unwrapped,
                  skip_render_check=True)  # headless, human mode warns by design (tests/envs/test_env_v1.py checks it)
    assert [str(w.message) for w in caught if not _newer_version(w)] == []


def test_sb3_env_checker_has_no_warnings() -> None:
    from stable_baselines3.common.env_checker import check_env
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(gym.make("TriPlanarShear-v0"), warn=True)
    assert [str(w.message) for w in caught if not _newer_version(w)] == []


def test_spaces_and_observations_stay_in_bounds() -> None:
    env = TriPlanarShearEnv()
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    assert env.observation_space.shape == (S.OBS_DIM,) and env.observation_space.dtype == np.float32
    assert np.all(np.isfinite(env.observation_space.high))
    env.action_space.seed(3)
    for step in rollout(env, [env.action_space.sample() for _ in range(300)], seed=3):
        obs = step[0]
        assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    # The first observation: 5 ms after rest at the load level, tip on the centreline, reference near rest.
    obs, info = env.reset(seed=1, options={"load_N": 40.0})
    assert obs[S.OBS_LOAD] == 40.0 and info["load_N"] == 40.0
    assert obs[S.OBS_TIME] == pytest.approx(0.005)
    assert 0 < obs[S.OBS_POS] < 1e-4 and obs[S.OBS_OFFSET] == 0.0
    assert np.allclose(obs[S.OBS_PREV:S.OBS_PREV + 2], [0.0, 0.0])


def test_same_seed_and_actions_give_bitwise_identical_rollouts() -> None:
    actions = np.random.default_rng(7).uniform(-1, 1, (400, 2)).astype(np.float32)
    first = rollout(TriPlanarShearEnv(), actions, seed=11)
    second = rollout(TriPlanarShearEnv(), actions, seed=11)
    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert np.array_equal(a[0], b[0])
        if len(a) == 5:
            assert a[1] == b[1] and a[2] == b[2] and a[3] == b[3] and a[4] == b[4]
    assert any(len(s) == 5 and s[4]["adaptive_steps"] for s in first)  # the adaptive path was exercised


def test_pickled_env_continues_identically() -> None:
    env = TriPlanarShearEnv(load_N=30.3)
    env.reset(seed=5)
    actions = np.random.default_rng(1).uniform(-0.3, 0.3, (60, 2)).astype(np.float32)
    for a in actions[:20]:
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    for a in actions[20:]:
        s1, s2 = env.step(a), clone.step(a)
        assert np.array_equal(s1[0], s2[0]) and s1[1:4] == s2[1:4]
        if s1[2] or s1[3]:
            break


def test_reward_on_a_hand_checked_state() -> None:
    """Block at rest, reference displaced 3 mm along x1 and 4 mm along x3 everywhere: d = 5 mm at each contact."""
    env = TriPlanarShearEnv(load_N=27.8)
    env.reset(seed=0)
    model = env.model
    y, p = model.initial_state(), model.kernel_params()
    st = env._st.copy()
    st[S.ST_DPREV], st[S.ST_SPREV], st[S.ST_A0], st[S.ST_A1] = 1.0, -0.0008, 0.0, 0.0
    st[S.ST_ERR_NUM] = st[S.ST_ERR_DEN] = 0.0
    ref = np.zeros((S.REFERENCE_POINTS, 9))
    ref[:, 0::3], ref[:, 2::3] = 0.003, 0.004
    obs, inf = np.empty(S.OBS_DIM), np.empty(S.N_INFO)
    cfg = env.config.packed()
    S._finish(y, p, st.copy(), ref, np.array([0.5, -0.5]), cfg, S.RUNNING, obs, inf, S.new_workspace())
    assert inf[S.IN_DIST] == pytest.approx(5.0, abs=1e-9)
    assert inf[S.IN_TRAVEL] == pytest.approx(0.0, abs=1e-12)
    assert inf[S.IN_R_DIST] == pytest.approx(-0.5 * (1.0 + 5.0) * 0.0008 / 0.08)   # -0.03
    assert inf[S.IN_R_RATE] == pytest.approx(-0.005 * (0.5 ** 2 + 0.5 ** 2))       # -0.0025
    assert inf[S.IN_R_TERM] == 0.0
    assert inf[S.IN_REWARD] == pytest.approx(-0.0325)
    assert inf[S.IN_ERR] == pytest.approx(3.0)                                     # (1 + 5) / 2 over 0.8 mm
    # (the outcome as the compiled step passes it, an int: an IntEnum would compile a second version of _finish)
    S._finish(y, p, st.copy(), ref, np.array([0.5, -0.5]), cfg, int(Outcome.ARRESTED), obs, inf, S.new_workspace())
    assert inf[S.IN_R_TERM] == pytest.approx(-50.0)                               # nothing of 8 cm travelled
    assert inf[S.IN_REWARD] == pytest.approx(-50.0325)
    step_weighted = replace(env.config, reward_weighting="step").packed()
    S._finish(y, p, st.copy(), ref, np.array([0.0, 0.0]), step_weighted, S.RUNNING, obs, inf, S.new_workspace())
    assert inf[S.IN_R_DIST] == pytest.approx(-5.0)


def test_reward_terms_follow_the_documented_formula_along_an_episode() -> None:
    env = TriPlanarShearEnv(load_N=35.0)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(2)
    prev_d, prev_s, prev_a, total_distance = 0.0, 0.0, np.zeros(2), 0.0
    d0 = np.hypot(*(obs[[S.OBS_POS, S.OBS_POS + 2]] - obs[[S.OBS_REF, S.OBS_REF + 2]])) * 1e3
    prev_d = env._st[S.ST_DPREV]
    assert prev_d == pytest.approx(np.mean([np.hypot(obs[3 * i] - obs[S.OBS_REF + 3 * i],
                                                     obs[3 * i + 2] - obs[S.OBS_REF + 3 * i + 2])
                                            for i in range(3)]) * 1e3, abs=1e-3)
    assert d0 >= 0
    prev_s = env._st[S.ST_SPREV]
    while True:
        a = np.clip(np.array([0.0, 0.0]) + rng.normal(0, 0.05, 2), -1, 1).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(a)
        pos, ref = obs[:9].reshape(3, 3), obs[S.OBS_REF:S.OBS_REF + 9].reshape(3, 3)
        d = np.mean(np.hypot(pos[:, 0] - ref[:, 0], pos[:, 2] - ref[:, 2])) * 1e3
        assert info["distance_mm"] == pytest.approx(d, abs=2e-3)  # observations are float32
        s = info["travel_m"]
        assert info["reward_distance"] == pytest.approx(-0.5 * (prev_d + info["distance_mm"]) * abs(s - prev_s) / 0.08)
        assert info["reward_action_rate"] == pytest.approx(-0.005 * np.sum((a.astype(float) - prev_a) ** 2))
        assert reward == pytest.approx(info["reward_distance"] + info["reward_action_rate"] + info["reward_termination"])
        total_distance += info["reward_distance"]
        prev_d, prev_s, prev_a = info["distance_mm"], s, a.astype(float)
        if terminated or truncated:
            break
    assert info["reason"] == "travel" and info["reward_termination"] == 0.0
    # Summed distance terms: minus the travel-averaged error, over the travel after the first 5 ms.
    assert -total_distance == pytest.approx(info["mimicry_error_mm"], rel=1e-3)


def test_every_termination_reason_is_reachable() -> None:
    terminated, _, info, _ = run_constant(TriPlanarShearEnv(load_N=55.6), [0.0, 0.0])
    assert terminated and info["reason"] == "travel" and info["is_success"]
    assert info["travel_m"] == pytest.approx(0.08, abs=1e-12) and info["reward_termination"] == 0.0
    terminated, _, info, _ = run_constant(TriPlanarShearEnv(load_N=55.6, thrust_scale=10.0), [1.0, 0.0])
    assert terminated and info["reason"] == "lift_off"
    terminated, _, info, k = run_constant(TriPlanarShearEnv(load_N=27.8), [-1.0, 0.0])
    assert terminated and info["reason"] == "left_plane" and k <= 1  # CP3 starts where the three planes meet
    assert info["travel_m"] < 1e-4
    assert info["reward_termination"] == pytest.approx(-50.0 * (1 - info["travel_m"] / 0.08))
    # Cut the thrust after 10 periods: the block stops and friction holds it (the statics LP decides).
    terminated, _, info, _ = run_constant(TriPlanarShearEnv(load_N=27.8), [0.0, 0.0], switch=(10, [-0.3, 0.0]))
    assert terminated and info["reason"] == "arrested" and 0 < info["travel_m"] < 0.002
    specimen = replace(reference()[0], mass_centre_m=np.array([0.115, 0.1, -0.005]))  # tall, near an edge
    terminated, _, info, _ = run_constant(TriPlanarShearEnv(load_N=40.0, specimen=specimen), [0.0, 0.0])
    assert terminated and info["reason"] == "mass_centre_outside"
    terminated, truncated, info, k = run_constant(TriPlanarShearEnv(load_N=27.8, time_limit_s=0.05), [0.0, 0.0])
    assert truncated and not terminated and info["reason"] == "time_limit" and k == 8  # 10 periods incl. the first
    assert info["reward_termination"] < 0


def test_held_block_does_not_creep_and_energy_balances() -> None:
    """Periods whose fixed RK4 steps break the energy balance by more than 1e-8 J (near stops, and the tracking tip's
    slowly slipping tip) are redone adaptively; the balance then holds over the whole test."""
    env = TriPlanarShearEnv(load_N=27.8)
    env.reset(seed=0)
    model = env.model
    y0 = model.initial_state()

    def residual(y: np.ndarray) -> float:
        potential = model.specimen.mass_kg * 9.81 * (y[K.S_R + 1] - y0[K.S_R + 1])
        kinetic = K.kinetic_energy_ws(y, env._p, K.new_workspace())
        return y[K.S_WLOAD] - kinetic - potential - y[K.S_DC:K.S_DC + 3].sum() - y[K.S_DTIP]

    from agents import TrackingTip
    controller = TrackingTip()
    controller.setup(env.config)
    obs, _ = env.reset(seed=0)
    adaptive = 0
    while True:
        obs, _, terminated, truncated, info = env.step(controller.act(obs))
        adaptive += info["adaptive_steps"]
        if terminated or truncated:
            break
    assert adaptive > 0 and info["reason"] == "travel"
    assert abs(residual(env._y)) < 1e-6  # J; the work done is ~0.3 J
    # The kernel steps to each predicted stop, so even without the check a cut drive ends in an arrest (before
    # the predictive stop, fixed steps let the held block creep on for the whole 2 s).
    unchecked = TriPlanarShearEnv(load_N=27.8, energy_tol_J=0.0)
    terminated, _, info, _ = run_constant(unchecked, [0.0, 0.0], switch=(10, [-0.3, 0.0]))
    assert terminated and info["reason"] == "arrested"


def test_constant_steel_tip_reproduces_the_core_simulation() -> None:
    env = TriPlanarShearEnv(load_N=40.0)
    terminated, _, info, _ = run_constant(env, [0.0, 0.0])
    assert info["reason"] == "travel"
    core = simulate(paper_model("A", 40.0), method="rk4", dt=0.005)
    cps = np.empty((3, 3))
    K.contact_points(env._y, env._p, cps)
    assert core.status.label == "travel"
    assert info["time_s"] == pytest.approx(core.t[-1], abs=1e-12)
    assert np.abs(cps - core.contact_points[-1]).max() < 1e-9
    # and the reference is the core's case C at the same load
    ref = simulate(paper_model("C", 40.0)).resample_by_travel(np.array([0.0, 0.04, 0.08]))
    assert np.abs(env.reference_path[[0, 80, 160]] - ref).max() < 1e-12


def test_reset_options_and_friction_noise() -> None:
    env = TriPlanarShearEnv(load_range=(30.0, 50.0))
    loads = {env.reset(seed=s)[1]["load_N"] for s in range(3)}
    assert len(loads) == 3 and all(30.0 <= f <= 50.0 for f in loads)
    env = TriPlanarShearEnv()
    assert {env.reset(seed=s)[1]["load_N"] for s in range(40)} <= set(S.PAPER_LOADS_N)
    obs, info = env.reset(seed=4, options={"load_N": 45.0, "friction_noise_deg": 1.0, "tip_friction_noise_deg": 2.0})
    again = TriPlanarShearEnv().reset(seed=4, options={"load_N": 45.0, "friction_noise_deg": 1.0,
                                                       "tip_friction_noise_deg": 2.0})
    assert info["friction_deg"] != (17.0, 14.0, 11.0) and info == again[1] and np.array_equal(obs, again[0])
    assert all(abs(a - b) <= 1.0 for a, b in zip(info["friction_deg"], (17.0, 14.0, 11.0)))
    assert env.model.specimen.friction_deg == info["friction_deg"]
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(options={"speed": 1})
    with pytest.raises(ValueError, match="offset_range_m"):
        TriPlanarShearEnv(offset_range_m=-1.0)


def test_render_rgb_array() -> None:
    env = TriPlanarShearEnv(load_N=40.0, render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.zeros(2, np.float32))
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8 and frame.std() > 0
    env.close()
