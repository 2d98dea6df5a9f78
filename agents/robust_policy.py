"""A finished ``TriPlanarShear-v1`` run (:mod:`agents.trainer`) as a bench controller (``reset``/``act`` on raw bench
observations): the frame-stack PPO (``ppo_robust``) keeps its frame stack itself, the recurrent PPO
(``ppo_recurrent``) its LSTM state.

The SB3 zips and ``vecnormalize.pkl`` are read with (cloud)pickle, which can run code: load only runs you trained
(:mod:`agents.ppo_controller`'s untrusted loaders, called with a run the caller named).
"""

from __future__ import annotations

import json
from collections import deque
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .controller_base import Controller
from .ppo_controller import load_untrusted_sb3_zip, load_untrusted_vecnormalize
from .privileged import privileged_row, truth_scale
from .train_config import ALGOS, PRIVILEGED, REFERENCE_DEVIATION, extra_input_of, frame_stack_of

FRAMES = 4             # the frame stack of a run that does not say (runs from before config.json)


class RobustPolicy(Controller):
    """A trained robust PPO as ``policy(obs) -> action`` on raw bench observations: keeps the frame stack itself
    (filled with the first observation of an episode, as ``FrameStackObservation`` pads)."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_robust", frames: int = FRAMES):
        self.model, self.normalizer, self.name, self.n_frames = model, normalizer, name, frames
        self.frames: deque = deque(maxlen=frames)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_robust") -> RobustPolicy:
        run_dir = Path(run_dir)  # UNPICKLES: a run the caller named (agents.ppo_controller's untrusted loaders)
        normalizer = load_untrusted_vecnormalize(run_dir / "vecnormalize.pkl")
        frames = frame_stack_of(run_config(run_dir)) if (run_dir / "config.json").exists() else FRAMES
        return cls(load_untrusted_sb3_zip(run_dir / "final_model.zip"), normalizer, name, frames)

    def reset(self, load_N: float, config: Any) -> None:
        self.frames.clear()

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self._decide(self._stack(obs))

    def _stack(self, obs: np.ndarray) -> np.ndarray:
        if not self.frames:
            self.frames.extend([obs] * self.n_frames)
        else:
            self.frames.append(obs)
        return np.concatenate(list(self.frames)).astype(np.float32)

    def _decide(self, policy_input: np.ndarray) -> np.ndarray:
        action, _ = self.model.predict(self.normalizer.normalize_obs(policy_input), deterministic=True)
        return np.asarray(action, dtype=np.float32)


class _EnvReadingPolicy(RobustPolicy):
    """A robust PPO whose input after the frame stack is read from the env it is bound to, as ``limit`` reads the
    true state (``needs_env``; :func:`agents.controller_base.play` binds it): a teacher's policy, no laboratory can
    run it."""

    needs_env = True

    def __init__(self, model: Any, normalizer: Any, name: str, frames: int = FRAMES):
        super().__init__(model, normalizer, name, frames)
        self._env: Any = None

    def bind(self, env: Any) -> None:
        self._env = env.unwrapped


class PrivilegedPolicy(_EnvReadingPolicy):
    """A robust PPO trained with ``env: privileged: true``: its input is the frame stack, then the privileged row of
    the episode's bench (:func:`agents.privileged.privileged_row`), read at :meth:`reset` from the bound env."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_privileged", frames: int = FRAMES):
        super().__init__(model, normalizer, name, frames)
        self._truth: np.ndarray | None = None

    def reset(self, load_N: float, config: Any) -> None:
        super().reset(load_N, config)
        self._truth = None
        if self._env is not None:
            self._truth = privileged_row(self._env.episode_bench, truth_scale(*config.base_specimen()))

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self._truth is None:
            raise RuntimeError(f"{self.name} needs the episode's true bench: call bind(env) after env.reset, then "
                               "reset (agents.controller_base.play does)")
        return self._decide(np.concatenate([self._stack(obs), self._truth]))


class DeviationPolicy(_EnvReadingPolicy):
    """A robust PPO trained with ``env: reference_deviation: true``: its input is the frame stack, then the
    episode's deviation from its true hydrostatic reference and the reference's slope now
    (:meth:`envs.base.ShearEnvBase.reference_deviation`, the same function the training batch calls), read at each
    decision from the bound env. A privileged policy: a bench would have to estimate it."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_deviation", frames: int = FRAMES):
        super().__init__(model, normalizer, name, frames)

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self._env is None:
            raise RuntimeError(f"{self.name} reads the episode's deviation from its true reference: call bind(env) "
                               "first (agents.controller_base.play does)")
        return self._decide(np.concatenate([self._stack(obs), self._deviation().astype(np.float32)]))

    def _deviation(self) -> np.ndarray:
        """The input after the frame stack (a probe of an estimator's error overrides it)."""
        return self._env.reference_deviation()


EXTRA_POLICIES = {PRIVILEGED: PrivilegedPolicy, REFERENCE_DEVIATION: DeviationPolicy}   # train_config.EXTRA_INPUTS


class RecurrentPolicy(Controller):
    """A trained recurrent PPO (``RecurrentPPO``) as ``policy(obs) -> action`` on raw bench observations: keeps the
    LSTM state itself, reset at each episode's start."""

    def __init__(self, model: Any, normalizer: Any, name: str = "ppo_recurrent"):
        self.model, self.normalizer, self.name = model, normalizer, name
        self.state: Any = None
        self.episode_start = np.ones((1,), dtype=bool)

    @classmethod
    def load(cls, run_dir: str | Path, name: str = "ppo_recurrent") -> RecurrentPolicy:
        run_dir = Path(run_dir)  # UNPICKLES: a run the caller named (agents.ppo_controller's untrusted loaders)
        normalizer = load_untrusted_vecnormalize(run_dir / "vecnormalize.pkl")
        return cls(load_untrusted_sb3_zip(run_dir / "final_model.zip", "recurrent"), normalizer, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.state = None
        self.episode_start = np.ones((1,), dtype=bool)

    def act(self, obs: np.ndarray) -> np.ndarray:
        normalized = self.normalizer.normalize_obs(np.asarray(obs, dtype=np.float32)[None, :])
        action, self.state = self.model.predict(normalized, state=self.state, episode_start=self.episode_start,
                                                deterministic=True)
        self.episode_start = np.zeros((1,), dtype=bool)
        return np.asarray(action[0], dtype=np.float32)


def run_config(run_dir: str | Path) -> dict[str, Any]:
    """The configuration a run trained with (its ``config.json``)."""
    return json.loads((Path(run_dir) / "config.json").read_text())


def policy_of_model(model: Any, normalizer: Any, algo: str, frames: int, extra: str | None = None
                    ) -> RobustPolicy | RecurrentPolicy:
    """A model in training (and its normaliser) as a bench controller (``extra``: the run's privileged input,
    :func:`agents.train_config.extra_input_of`, read by its :data:`EXTRA_POLICIES` class)."""
    if algo == "recurrent":
        return RecurrentPolicy(model, normalizer)
    return EXTRA_POLICIES.get(extra, RobustPolicy)(model, normalizer, frames=frames)


def load_policy(run_dir: str | Path, algo: str = "ppo", name: str | None = None) -> RobustPolicy | RecurrentPolicy:
    """A finished v1 run as a bench controller (``reset``/``act``); a run trained with ``env.privileged`` as a
    :class:`PrivilegedPolicy`, with ``env.reference_deviation`` as a :class:`DeviationPolicy`."""
    cls = RecurrentPolicy if algo == "recurrent" else RobustPolicy
    extra = extra_input_of(run_config(run_dir)) if (Path(run_dir) / "config.json").exists() else None
    if cls is RobustPolicy and extra is not None:
        return EXTRA_POLICIES[extra].load(run_dir, name=name or f"ppo_{extra}")
    return cls.load(run_dir, name=name or ALGOS[algo])


def evaluate_policy_on(policy: RobustPolicy | RecurrentPolicy, benches: Sequence[Any],
                       env_kwargs: dict[str, Any] | None = None, bench_set: str = "heldout",
                       tip_friction_deg: float | None = None) -> list[Any]:
    from .heldout import run_episode, with_tip
    return [run_episode(policy, with_tip(b, tip_friction_deg), env_kwargs=env_kwargs, seed=i, bench_set=bench_set,
                        index=i) for i, b in enumerate(benches)]
