"""A banked agent's recurrent starter runs in numpy (:mod:`agents.zoo.starter`): it acts as the shipped agent's SB3
step does, to float32 rounding, from a zeroed LSTM state at every reset; every builder of a started agent makes its
starter the same way."""

from __future__ import annotations

import numpy as np

from agents.zoo import load_shipped, load_starter
from agents.zoo.starter import NumpyRecurrentStarter


def test_the_numpy_lstm_acts_as_the_shipped_recurrent_agent_to_float32_rounding():
    agent = load_shipped("ppo_recurrent", 1)
    starter = load_starter("ppo_recurrent", 1)
    assert isinstance(starter, NumpyRecurrentStarter)
    env = agent.make_env()
    for episode in range(2):
        obs, _ = env.reset(seed=episode)
        agent.reset()
        starter.reset()
        for _ in range(40):
            want, have = agent.act(obs), starter.act(obs)
            assert have.dtype == np.float32 and np.max(np.abs(have - want)) < 1e-5
            obs, _, terminated, truncated, _ = env.step(want)
            if terminated or truncated:
                break
    assert not isinstance(load_starter("ppo_robust", 0), NumpyRecurrentStarter)   # a frame stack runs as shipped
