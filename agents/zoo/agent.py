"""A shipped agent as SB3 users expect it: ``predict(obs, state=None, episode_start=None, deterministic=True) ->
(action, state)``, ``reset()``, ``agent(obs) -> action``, ``make_env()``; rebuilt from data files only.

One seed of an agent is two files: ``policy.safetensors`` (the SB3 policy's ``state_dict``, tensors only: the
format cannot hold code) and ``normalizer.json`` (VecNormalize's observation statistics and settings). The SB3
policy object (``ActorCriticPolicy``, or sb3-contrib's ``RecurrentActorCriticPolicy``) is built from the model
card's hyperparameters and the env's spaces, then the tensors are loaded into it: nothing is unpickled.

The agent's memory (the frame stack of a ``ppo`` agent, the LSTM state of a ``recurrent`` one) is the ``state`` of
SB3's contract: pass back what ``predict`` returned and ``episode_start`` (True where an episode begins), as with
``RecurrentPPO``. Called without ``state`` and ``episode_start`` (``action, _ = agent.predict(obs)``, SB3's habit
for feed-forward models) the agent keeps the memory itself: ``reset()`` clears it, and an observation whose time
(the ``TIME`` field) is not later than the previous one's starts a new episode, so a forgotten ``reset()`` does not
carry the last episode's frames or LSTM state into the next.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from ..controller_base import Controller
from .cards import ShippedAgentError, bench_arguments_of_env, check_bench

POLICY = "policy.safetensors"
NORMALIZER = "normalizer.json"
POLICY_CLASSES = {"ppo": "MlpPolicy", "recurrent": "MlpLstmPolicy", "banked": "MlpPolicy"}
# The policy constructor arguments a card may set (what the shipped agents' YAML files use), each checked.
POLICY_KWARGS = {"net_arch": list, "log_std_init": float, "ortho_init": bool, "lstm_hidden_size": int,
                 "n_lstm_layers": int, "enable_critic_lstm": bool, "shared_lstm": bool}


class ObsNormalizer:
    """VecNormalize's observation normalisation (``normalize_obs``, the same arithmetic to the bit) from its
    statistics: ``clip((obs - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)`` as float32."""

    def __init__(self, mean: np.ndarray, var: np.ndarray, epsilon: float, clip_obs: float, count: float = 0.0):
        self.mean, self.var = np.asarray(mean, dtype=np.float64), np.asarray(var, dtype=np.float64)
        self.epsilon, self.clip_obs, self.count = float(epsilon), float(clip_obs), float(count)

    def normalize_obs(self, obs: np.ndarray) -> np.ndarray:
        return np.clip((obs - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip_obs,
                       self.clip_obs).astype(np.float32)

    def to_json(self) -> str:
        return json.dumps({"norm_obs": True, "mean": self.mean.tolist(), "var": self.var.tolist(),
                           "count": self.count, "epsilon": self.epsilon, "clip_obs": self.clip_obs}, indent=1) + "\n"

    @classmethod
    def from_json(cls, text: bytes | str, size: int, source: str) -> ObsNormalizer:
        """Read and check (sizes, finite values, a positive variance) the statistics of ``normalizer.json``."""
        try:
            data = json.loads(text)
        except (ValueError, RecursionError) as err:
            raise ShippedAgentError(f"{source}: not JSON ({err})") from None
        if not isinstance(data, dict) or data.get("norm_obs") is not True:
            raise ShippedAgentError(f"{source}: field 'norm_obs' must be true (observations normalised)")
        arrays = {}
        for key in ("mean", "var"):
            value = data.get(key)
            if not (isinstance(value, list) and len(value) == size and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
                raise ShippedAgentError(f"{source}: field {key!r} must be {size} finite numbers")
            arrays[key] = np.array(value, dtype=np.float64)
        if np.any(arrays["var"] < 0):
            raise ShippedAgentError(f"{source}: field 'var' must be >= 0")
        for key in ("epsilon", "clip_obs", "count"):
            value = data.get(key)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
                    and value >= 0):
                raise ShippedAgentError(f"{source}: field {key!r} must be a finite number >= 0, got {value!r}")
        return cls(arrays["mean"], arrays["var"], data["epsilon"], data["clip_obs"], data["count"])


def card_env(card: dict[str, Any], render_mode: str | None = None) -> Any:
    """``gym.make(card env_id, **card env_kwargs)``: exactly the env the agent was trained on."""
    import gymnasium as gym

    import envs  # noqa: F401  (registers the ids)
    return gym.make(card["env_id"], render_mode=render_mode, **card["env_kwargs"])


def _policy_kwargs(card: dict[str, Any]) -> dict[str, Any]:
    kwargs = dict((card["hyperparameters"].get("hyperparams") or {}).get("policy_kwargs") or {})
    for key, value in kwargs.items():
        kind = POLICY_KWARGS.get(key)
        ok = kind is not None and (isinstance(value, kind) or (kind is float and isinstance(value, int)))
        if kind is int:
            ok = ok and not isinstance(value, bool) and 0 < value <= 4096
        if kind is list:
            ok = ok and len(value) <= 8 and all(isinstance(v, int) and not isinstance(v, bool) and 0 < v <= 4096
                                                for v in value)
        if not ok:
            raise ShippedAgentError(f"{card['name']}: field 'hyperparameters.hyperparams.policy_kwargs.{key}' is "
                                    f"not a policy argument the loader knows ({sorted(POLICY_KWARGS)}) of its type, "
                                    f"got {value!r}")
    return kwargs


def policy_spaces(card: dict[str, Any]) -> tuple[Any, Any]:
    """(observation space, action space) of the policy: the card's env's, its observation stacked ``frames``
    times (as the training's frame stack concatenates them); a ``banked`` agent's then widened by its bank's
    estimate of the reference deviation (unbounded, as its training env appended it)."""
    from gymnasium import spaces
    env = card_env(card)
    try:
        single, action = env.observation_space, env.action_space
    finally:
        env.close()
    frames = int(card["observation"]["frames"])
    low, high = np.tile(single.low, frames), np.tile(single.high, frames)
    if card["algo"] == "banked":
        from envs.core import REFERENCE_DEVIATION_DIM
        unbounded = np.full(REFERENCE_DEVIATION_DIM, np.inf, dtype=single.dtype)
        low, high = np.concatenate([low, -unbounded]), np.concatenate([high, unbounded])
    return spaces.Box(low, high, dtype=single.dtype), action


def build_policy(card: dict[str, Any], state_dict: dict[str, Any]) -> Any:
    """The SB3 policy object of ``card`` (its class and ``policy_kwargs``, the env's spaces) holding
    ``state_dict``'s tensors (strict: every tensor of the architecture, nothing else)."""
    policy_kwargs = _policy_kwargs(card)   # checked before anything is built
    observation_space, action_space = policy_spaces(card)
    if card["algo"] == "recurrent":
        from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy as policy_class
    else:
        from stable_baselines3.common.policies import ActorCriticPolicy as policy_class
    policy = policy_class(observation_space, action_space, lambda _: 0.0, **policy_kwargs)
    try:
        policy.load_state_dict(state_dict, strict=True)
    except (RuntimeError, KeyError) as err:
        raise ShippedAgentError(f"{card['name']}: the weights do not fit the card's policy ({err})") from None
    policy.set_training_mode(False)
    return policy


class ShippedAgent(Controller):
    """One training seed of a shipped agent (see the module docstring for the memory and ``state``)."""

    needs_env = True    # agents.heldout.run_episode binds the env it made: checked against the card (bind)

    def __init__(self, card: dict[str, Any], seed: int, policy: Any, normalizer: ObsNormalizer):
        self.card, self.seed, self.policy, self.normalizer = card, seed, policy, normalizer
        self.name = card["name"]
        self.recurrent = card["algo"] == "recurrent"
        self.frames = 1 if self.recurrent else int(card["observation"]["frames"])
        offsets = np.cumsum([0] + [size for _, size in card["observation"]["fields"]])
        self.obs_size = int(offsets[-1])
        # where each field of one observation starts (a frame's TIME tells a new episode; a banked agent's LOAD)
        self.field_offsets = {name: int(start) for (name, _), start in zip(card["observation"]["fields"], offsets)}
        self._time_index = self.field_offsets.get("TIME")
        self.reset()

    # -- SB3's contract ---------------------------------------------------------------------------------------
    def predict(self, observation: np.ndarray, state: Any = None, episode_start: np.ndarray | None = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """SB3's ``predict``: the action(s) for one observation of :meth:`make_env`'s env (shape ``(obs,)``) or a
        batch (``(n_envs, obs)``), and the memory to pass back as ``state`` next time."""
        obs = np.asarray(observation, dtype=np.float32)
        single = obs.ndim == 1
        batch = obs[None, :] if single else obs
        if batch.ndim != 2 or batch.shape[1] != self.obs_size:
            raise ShippedAgentError(f"shipped agent {self.name!r} takes observations of {self.obs_size} values "
                                    f"(or a batch of them), got shape {obs.shape}")
        n = batch.shape[0]
        own = state is None and episode_start is None
        if own:
            state, starts = self._own_memory(batch)
        else:
            starts = np.zeros(n, dtype=bool) if episode_start is None else np.asarray(episode_start, dtype=bool)
            if starts.shape != (n,):
                raise ShippedAgentError(f"episode_start must have one flag per observation ({n}), got shape "
                                        f"{starts.shape}")
        actions, new_state = self._step(batch, state, starts, deterministic)
        if own:
            self._state = new_state
        return (actions[0] if single else actions), new_state

    def reset(self, *bench: Any) -> None:
        """Forget the memory (frames, LSTM state): the next :meth:`predict` without ``state`` starts an episode.
        (The bench controllers' ``reset(load_N, config)`` arguments are accepted and not used.)"""
        self._state: Any = None
        self._last_time: np.ndarray | None = None

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        """``agent(obs) -> action``: :meth:`predict` deterministic, the agent keeping its memory."""
        return self.act(observation)

    def act(self, observation: np.ndarray) -> np.ndarray:
        action, _ = self.predict(observation)
        return np.asarray(action, dtype=np.float32)

    def make_env(self, render_mode: str | None = None) -> Any:
        """Exactly the env of the model card: ``gym.make(card['env_id'], **card['env_kwargs'])``."""
        return card_env(self.card, render_mode)

    def check_env(self, env: Any) -> None:
        """Refuse, naming the argument, an env whose bench differs from the model card's (another stage
        bandwidth, latency, noise, tip, observation mode...); what an episode draws (the specimen) may differ."""
        check_bench(self.card, bench_arguments_of_env(env))

    def bind(self, env: Any) -> None:
        """The bench controllers' hook (:func:`agents.heldout.run_episode` calls it with its env): :meth:`check_env`."""
        self.check_env(env)

    # -- memory -----------------------------------------------------------------------------------------------
    def _own_memory(self, batch: np.ndarray) -> tuple[Any, np.ndarray]:
        n = batch.shape[0]
        starts = np.zeros(n, dtype=bool)
        if self._state is None or self._last_time is None or self._last_time.shape != (n,):
            self._state, starts[:] = None, True
        if self._time_index is not None:
            time = batch[:, self._time_index].copy()
            if self._last_time is not None and self._last_time.shape == (n,):
                starts |= time <= self._last_time     # a new episode's clock starts again
            self._last_time = time
        else:
            self._last_time = np.zeros(n)
        return self._state, starts

    def _step(self, batch: np.ndarray, state: Any, starts: np.ndarray, deterministic: bool) -> tuple[np.ndarray, Any]:
        n = batch.shape[0]
        if self.recurrent:   # row by row, so that an env's actions in a batch are bitwise its actions alone
            normalized = self.normalizer.normalize_obs(batch)
            actions, hidden, cell = [], [], []
            for i in range(n):
                row_state = None if state is None else (state[0][:, i:i + 1], state[1][:, i:i + 1])
                action, (h, c) = self.policy.predict(normalized[i:i + 1], state=row_state,
                                                     episode_start=starts[i:i + 1].astype(np.float32),
                                                     deterministic=deterministic)
                actions.append(action[0])
                hidden.append(h)
                cell.append(c)
            return np.asarray(actions, dtype=np.float32), (np.concatenate(hidden, axis=1),
                                                           np.concatenate(cell, axis=1))
        if state is None:
            state = np.repeat(batch[:, None, :], self.frames, axis=1)
        state = np.asarray(state, dtype=np.float32)
        if state.shape != (n, self.frames, self.obs_size):
            raise ShippedAgentError(f"state must be the frames predict returned, shape {(n, self.frames, self.obs_size)}"
                                    f", got {state.shape}")
        stacked = np.concatenate([state[:, 1:], batch[:, None, :]], axis=1)
        stacked[starts] = np.repeat(batch[starts][:, None, :], self.frames, axis=1)   # padded as FrameStack pads
        actions = [self.policy.predict(self.normalizer.normalize_obs(row.reshape(-1)), deterministic=deterministic)[0]
                   for row in stacked]
        return np.asarray(actions, dtype=np.float32), stacked
