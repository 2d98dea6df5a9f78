"""The env refuses actions and reset options it cannot use, with a named error."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import envs  # noqa: F401 (registers TriPlanarShear-v0)


@pytest.fixture(scope="module")
def env():
    env = gym.make("TriPlanarShear-v0").unwrapped
    yield env
    env.close()


def rollout(env, actions) -> list:
    obs, _ = env.reset(seed=3, options={"load_N": 40.0})
    out = [obs]
    for a in actions:
        obs, reward, terminated, truncated, _ = env.step(a)
        out.append((obs, reward, terminated, truncated))
    return out


@pytest.mark.parametrize("action, error", [
    ([math.nan, 0.0], ValueError), ([0.0, math.inf], ValueError), (None, TypeError), ([None, 0.0], TypeError),
    (0.5, ValueError), ([0.5], ValueError), ([0.5, 0.1, 0.2], ValueError), ([[0.5, 0.1]], ValueError),
    ([0.5 + 1j, 0.0], TypeError), ("ab", TypeError), (["0.5", "0.1"], TypeError), ([True, False], TypeError),
])
def test_bad_actions_raise_a_named_error_and_leave_the_state_alone(env, action, error) -> None:
    reference = rollout(env, [[0.3, -0.2]] * 3)
    env.reset(seed=3, options={"load_N": 40.0})
    env.step([0.3, -0.2])
    with pytest.raises(error, match="action"):
        env.step(action)
    for expected in reference[2:]:
        obs, reward, terminated, truncated, _ = env.step([0.3, -0.2])
        assert np.array_equal(obs, expected[0]) and reward == expected[1] and np.isfinite(reward)
        assert (terminated, truncated) == expected[2:]


def test_valid_actions_of_every_accepted_type_give_bitwise_equal_results(env) -> None:
    base = rollout(env, [np.array([0.25, 0.5])] * 4)
    for kind in (lambda a: list(a), tuple, lambda a: np.asarray(a, np.float32).astype(np.float64),
                 lambda a: np.asarray(a, np.float64)):
        other = rollout(env, [kind(np.array([0.25, 0.5]))] * 4)
        for x, y in zip(base[1:], other[1:]):
            assert np.array_equal(x[0], y[0]) and x[1] == y[1]
    # integers and out-of-range values are valid (clipped to [-1, 1])
    assert np.array_equal(rollout(env, [[1, 0]])[1][0], rollout(env, [[1.0, 0.0]])[1][0])
    assert np.array_equal(rollout(env, [[7.0, -3.0]])[1][0], rollout(env, [[1.0, -1.0]])[1][0])


@pytest.mark.parametrize("options, name", [
    ({"friction_noise_deg": -1.0}, "friction_noise_deg"), ({"friction_noise_deg": math.nan}, "friction_noise_deg"),
    ({"tip_friction_noise_deg": -0.5}, "tip_friction_noise_deg"), ({"load_range": (50.0, 30.0)}, "load_range"),
    ({"load_range": 5}, "load_range"), ({"load_range": (1.0,)}, "load_range"), ({"load_levels": []}, "load_levels"),
    ({"load_levels": [30.0, "x"]}, "load_levels"), ({"load_levels": 30.0}, "load_levels"),
    ({"load_N": -3.0}, "load_N"), ({"load_N": math.nan}, "load_N"),
])
def test_bad_reset_options_raise_a_named_value_error(env, options, name) -> None:
    with pytest.raises(ValueError, match=f"reset option {name}"):
        env.reset(seed=0, options=options)


real = st.floats(allow_nan=True, allow_infinity=True, width=64)
actions = st.one_of(
    st.lists(real, min_size=0, max_size=4), st.tuples(real, real), real, st.none(), st.text(max_size=4),
    st.lists(st.one_of(real, st.none(), st.text(max_size=2), st.booleans(), st.complex_numbers(), st.integers()),
             min_size=1, max_size=3),
    st.builds(lambda a, b: np.array([a, b]), real, real),
)


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))  # inputs: the profile (tests/conftest.py)
@given(action=actions)
def test_fuzz_actions_give_a_named_error_or_a_finite_step(env, action) -> None:
    env.reset(seed=0, options={"load_N": 35.0})
    try:
        obs, reward, terminated, truncated, info = env.step(action)
    except (TypeError, ValueError) as err:
        assert "action" in str(err)
        return
    assert np.all(np.isfinite(obs)) and math.isfinite(reward)


def test_vector_env_refuses_bad_actions_before_touching_its_state() -> None:
    from envs.vector import TriPlanarShearVectorEnv
    envs_ = TriPlanarShearVectorEnv(3)
    envs_.reset(seed=1, options={"load_N": 40.0})
    good = np.array([[0.3, -0.2]] * 3)
    for bad, error in ((np.array([[0.3, -0.2], [math.nan, 0.0], [0.0, 0.0]]), ValueError),
                       (np.zeros((2, 2)), ValueError), (np.zeros(6), ValueError), (None, TypeError),
                       (np.zeros((3, 2), complex), TypeError)):
        with pytest.raises(error, match="actions"):
            envs_.step(bad)
    obs, rewards, *_ = envs_.step(good)
    fresh = TriPlanarShearVectorEnv(3)
    fresh.reset(seed=1, options={"load_N": 40.0})
    obs2, rewards2, *_ = fresh.step(good)
    assert np.array_equal(obs, obs2) and np.array_equal(rewards, rewards2) and np.all(np.isfinite(rewards))
