"""A shipped agent that runs a specimen bank beside its policy (model card ``algo: banked``): the controller of
:mod:`agents.banked_deviation` (``banked:RUN``) from the zoo's data files.

Each period the bank (:class:`agents.deviation_bank.DeviationBank`: ``mpc``'s bank of the card's ``bank_size``
hypotheses, no resample-move, weights tempered to an effective size of 4) is weighed by the new observation; its
estimate of the block's deviation from its case-C reference (12 values; with the card's ``tracker``, the bank's
Gauss-Newton tracker's, run behind the decision as a bench runs it: :func:`agents.deviation_tracker.
deviation_estimator`) is appended to the frame stack; the policy
(a flat MLP, run in numpy: :class:`agents.banked_deviation.NumpyActor`) decides; then the bank advances every
hypothesis by the command decided (on a bench: after the command is sent, in the period's slack). ``agent.info``
holds the last period's thread CPU to the decision (``decision_cpu_s``) and in all (``period_cpu_s``). With the
card's ``starter``, that shipped agent (``starter``: made by :func:`agents.zoo.load_starter`) decides the
first ``starter.periods`` periods instead of the policy; the bank and the frame stack see those periods all the same.

**Memory.** The frame stack and the bank are one episode's, kept by the agent: ``predict`` takes one observation at
a time (not a batch: a bank is one bench's) and returns ``state`` None. An episode starts at :meth:`reset`, at an
``episode_start`` flag, or at an observation whose ``TIME`` is not later than the last one's. Its bank starts in
``reset(load_N, config)`` when given (what the project's episode loop passes: the bench's load, before the test),
else at the episode's first observation, from its ``LOAD`` field on the card's bench. Deterministic only (the
Gaussian's mean, as ``deterministic=True``).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from .agent import ObsNormalizer, ShippedAgent, card_env
from .cards import ShippedAgentError


class BankedAgent(ShippedAgent):
    """One training seed of a ``banked`` shipped agent (module docstring)."""

    def __init__(self, card: dict[str, Any], seed: int, policy: Any, normalizer: ObsNormalizer,
                 starter: Any = None):
        from ..banked_deviation import BankedDeviationPolicy
        from ..robust_policy import DeviationPolicy
        model = SimpleNamespace(policy=policy, action_space=policy.action_space)   # what NumpyActor reads
        frames = int(card["observation"]["frames"])
        start = {"starter": starter, "start_periods": int(card["starter"]["periods"])} if starter is not None else {}
        self.controller = BankedDeviationPolicy.with_bank(DeviationPolicy(model, normalizer, card["name"], frames),
                                                          card["bank_size"], bool(card.get("tracker", False)),
                                                          name=card["name"], **start)
        self._card_config: Any = None
        super().__init__(card, seed, policy, normalizer)
        self._load_index = self.field_offsets.get("LOAD")

    @property
    def info(self) -> dict[str, float]:
        """The last period's thread CPU: to the decision, and in all (the bank's advance included)."""
        return self.controller.info

    def reset(self, *bench: Any) -> None:
        """Start a new episode at the next observation; ``reset(load_N, config)`` (the project's episode loop) gives
        the bench's load and config, and the bank's hypotheses are started here, before the test (tens of ms: a
        bench's setup, not a period's work)."""
        super().reset()
        self._prepared = len(bench) == 2 and bench[1] is not None
        if self._prepared:
            self.controller.reset(float(bench[0]), bench[1])

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """SB3's ``predict`` for one observation of :meth:`make_env`'s env: ``(action, None)`` (module docstring)."""
        obs = np.asarray(observation, dtype=np.float32)
        if obs.shape != (self.obs_size,):
            raise ShippedAgentError(f"shipped agent {self.name!r} runs one bench at a time (its specimen bank is one "
                                    f"episode's): give one observation of {self.obs_size} values, got shape {obs.shape}")
        if state is not None:
            raise ShippedAgentError(f"shipped agent {self.name!r} keeps its memory itself (frames and specimen bank): "
                                    "pass state=None (predict returns None)")
        if not deterministic:
            raise ShippedAgentError(f"shipped agent {self.name!r} acts deterministically only: deterministic=False "
                                    "is not offered")
        now = float(obs[self._time_index]) if self._time_index is not None else None
        flagged = episode_start is not None and bool(np.any(np.asarray(episode_start, dtype=bool)))
        started = self._last_time is None or flagged or (now is not None and now <= self._last_time)
        self._last_time = now if now is not None else -math.inf   # (no clock: only reset and the flag start one)
        if started and not self._prepared:
            self.controller.reset(*self._episode_bench(obs))
        self._prepared = False
        return self.controller.act(obs), None

    def _episode_bench(self, obs: np.ndarray) -> tuple[float, Any]:
        """(load, config) of an episode starting at ``obs`` without :meth:`reset`'s: the observation's load on the
        card's bench."""
        if self._load_index is None:
            raise ShippedAgentError(f"shipped agent {self.name!r}: the observation has no LOAD field; call "
                                    "reset(load_N, config) before each episode")
        if self._card_config is None:
            env = card_env(self.card)
            self._card_config = env.unwrapped.config
            env.close()
        return float(obs[self._load_index]), self._card_config
