"""A shipped agent behaves as an SB3 model: predict(obs, state, episode_start, deterministic) -> (action, state),
reset(), agent(obs), make_env() giving the card's env, and a refusal naming the argument on any other bench."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from agents.zoo import ShippedAgentError, load_shipped, read_card


@pytest.fixture(scope="module", params=["ppo_robust", "ppo_recurrent"])
def agent(request):
    return load_shipped(request.param, 0)


def _observations(env, n: int, seed: int = 0) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(n - 1):
        obs, *_ = env.step(np.zeros(2, np.float32))
        out.append(obs)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ppo_robust", "ppo_recurrent", "ppo_banked", "ppo_tracked"])
def test_an_episode_in_sb3s_recurrent_loop_equals_the_agents_own_memory(name):
    """The loop of SB3's docs (RecurrentPPO's: state and episode_start passed back) on gym.make(card env) runs a
    whole episode; its actions are bitwise the actions of agent(obs), the agent keeping its memory itself (a banked
    agent returns state None and starts its bank at the observation's load)."""
    agent = load_shipped(name, 0)
    env = gym.make(agent.card["env_id"], **agent.card["env_kwargs"])
    agent.check_env(env)
    obs, _ = env.reset(seed=3)
    state, episode_start = None, np.ones((1,), dtype=bool)
    actions, observations = [], []
    while True:
        action, state = agent.predict(obs, state=state, episode_start=episode_start, deterministic=True)
        observations.append(obs)
        actions.append(action)
        obs, reward, terminated, truncated, info = env.step(action)
        episode_start = np.array([terminated or truncated])
        if terminated or truncated:
            break
    assert len(actions) > 10 and info["is_success"] in (True, False)
    agent.reset()
    assert all(np.array_equal(agent(o), a) for o, a in zip(observations, actions))


def test_single_and_batched_observations_and_the_state_contract(agent):
    env = agent.make_env()
    first = _observations(env, 6, seed=1)
    second = _observations(env, 6, seed=2)
    agent.reset()
    one = [agent.predict(o)[0] for o in first]                    # SB3's feed-forward habit: no state passed
    assert one[0].shape == (2,) and one[0].dtype == np.float32
    state, batched = None, []
    for i, (a, b) in enumerate(zip(first, second)):
        action, state = agent.predict(np.stack([a, b]), state=state, episode_start=np.array([i == 0, i == 0]))
        assert action.shape == (2, 2)
        batched.append(action)
    assert all(np.array_equal(x, y[0]) for x, y in zip(one, batched))
    agent.reset()
    assert all(np.array_equal(agent.act(o), y[1]) for o, y in zip(second, batched))
    with pytest.raises(ShippedAgentError, match="observations of 15 values"):
        agent.predict(np.zeros(7, np.float32))


def test_a_new_episode_restarts_the_memory_even_without_reset(agent):
    """Forgetting reset() between episodes does not carry the last episode's frames or LSTM state over: the
    observation's clock going back starts a new episode."""
    env = agent.make_env()
    first, second = _observations(env, 8, seed=1), _observations(env, 4, seed=2)
    agent.reset()
    fresh = [agent(o) for o in second]
    agent.reset()
    for o in first:
        agent(o)
    assert all(np.array_equal(agent(o), f) for o, f in zip(second, fresh))


def test_make_env_is_the_cards_env_and_another_bench_is_refused_by_name():
    steel = load_shipped("ppo_steel_slow_noisy", 0)
    card = read_card("ppo_steel_slow_noisy")
    env = steel.make_env()
    assert env.spec.id == card["env_id"] and env.unwrapped.bench.stage_bandwidth_hz == 5.0
    steel.check_env(env)
    with pytest.raises(ShippedAgentError, match="stage_bandwidth_hz=5.0.*stage_bandwidth_hz=20.0"):
        steel.check_env(gym.make("TriPlanarShear-v1"))
    with pytest.raises(ShippedAgentError, match="latency_s"):
        steel.check_env(gym.make("TriPlanarShear-v1", **{**card["env_kwargs"], "latency_s": 0.0}))
    with pytest.raises(ShippedAgentError, match="env_id"):
        steel.check_env(gym.make("TriPlanarShear-v0"))
    from agents.heldout import heldout_benches, run_episode
    with pytest.raises(ShippedAgentError, match="stage_bandwidth_hz"):   # the bench controllers' episode too
        run_episode(steel, heldout_benches(1)[0])


@pytest.mark.slow
def test_evaluate_refuses_a_shipped_agent_on_another_design_naming_the_argument(tmp_path, capsys):
    from triplanar import cli
    out = tmp_path / "out"
    assert cli.main(["evaluate", "--controller", "ppo_steel_slow_noisy", "--design", "steel_lab", "--n", "1",
                     "--out", str(out)]) == 2
    assert "stage_bandwidth_hz=5.0" in capsys.readouterr().err
    assert cli.main(["evaluate", "--controller", "ppo_robust", "--design", "steel_slow_noisy", "--n", "1",
                     "--out", str(out)]) == 2
    assert "ppo_robust" in capsys.readouterr().err
    assert not out.exists()
