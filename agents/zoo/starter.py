"""The starter of a ``banked`` shipped agent (its card's ``starter``): another shipped agent that drives the first
decisions, run in numpy.

A recurrent agent's step through SB3's ``predict`` costs 0.5-0.6 ms on this machine at one observation, almost all
of it torch's overhead per call around a 64-cell LSTM and three small layers, and an episode's first step 3-6 ms;
:class:`NumpyRecurrentStarter` runs the same weights as float32 numpy (the LSTM's gates in torch's order, then
:class:`agents.banked_deviation.NumpyActor`'s head). Its float32 sums are not torch's to the last bit, so the agent
it starts is measured with it: :func:`agents.zoo.load_starter` is the one way every builder of such an agent (the
zoo's loader, ``banked:RUN?starter=...``, the shipping's check) makes its starter. A frame-stack starter runs through
its shipped agent as is.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-x))).astype(np.float32)


class NumpyRecurrentStarter:
    """A shipped recurrent agent's deterministic policy (normalisation, one LSTM layer, the actor's head) in numpy;
    the LSTM's state starts at zero at :meth:`reset`, as the agent's at an episode's start."""

    def __init__(self, agent: Any):
        from ..banked_deviation import NumpyActor
        policy = agent.policy
        lstm = policy.lstm_actor
        if lstm.num_layers != 1 or lstm.bidirectional or not lstm.bias or getattr(lstm, "proj_size", 0):
            raise ValueError(f"NumpyRecurrentStarter: {agent.name!r}'s LSTM is not one plain layer")
        weights = {name: tensor.detach().cpu().numpy().astype(np.float32) for name, tensor in lstm.named_parameters()}
        self.w_in, self.w_hidden = weights["weight_ih_l0"], weights["weight_hh_l0"]
        self.bias = weights["bias_ih_l0"] + weights["bias_hh_l0"]
        self.cells = lstm.hidden_size
        self.head = NumpyActor(SimpleNamespace(policy=policy, action_space=policy.action_space))
        self.normalizer, self.name = agent.normalizer, agent.name
        self.reset()

    def reset(self, *bench: Any) -> None:
        self.h = np.zeros(self.cells, dtype=np.float32)
        self.c = np.zeros(self.cells, dtype=np.float32)

    def act(self, obs: np.ndarray) -> np.ndarray:
        x = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32)[None, :])[0]
        gates = self.w_in @ x + self.w_hidden @ self.h + self.bias
        n = self.cells
        i, f, g, o = _sigmoid(gates[:n]), _sigmoid(gates[n:2 * n]), np.tanh(gates[2 * n:3 * n]), _sigmoid(gates[3 * n:])
        self.c = (f * self.c + i * g).astype(np.float32)
        self.h = (o * np.tanh(self.c)).astype(np.float32)
        return self.head(self.h)
