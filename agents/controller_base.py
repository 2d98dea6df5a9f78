"""The one controller contract (after safe-control-gym's ``BaseController`` and stable-baselines3's ``predict``):
every controller, scripted, model-based or learned, on ``TriPlanarShear-v0`` and ``-v1``, is a :class:`Controller`,
and :func:`play` is the one episode loop that runs it (:func:`agents.evaluation.evaluate` on v0,
:func:`agents.heldout.run_episode` on v1, and through it ``triplanar evaluate`` and the bench study).

What a controller knows of the bench is passed in explicitly: :meth:`Controller.reset` gets the episode's load level
and the env's :class:`envs.core.ShearConfig` (its task scaling and nominal specimen); a controller that reads the env
itself (``needs_env``: ``limit`` plans from its true state through ``get_state``, a shipped agent checks the bench
against its model card) is handed it by :meth:`Controller.bind` first.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np


class Controller:
    """Base class of the controllers: ``reset(load_N, config)`` at each episode's start, ``act(obs) -> action``
    each period, SB3's ``predict``; ``name`` labels its tables."""

    name: str = "controller"
    needs_env: bool = False   # True: play() calls bind(env) before reset

    def bind(self, env: Any) -> None:
        """Hand over the env (called only for a controller with ``needs_env``)."""

    def reset(self, load_N: float, config: Any) -> None:
        """A new episode at load level ``load_N`` on a bench configured by ``config`` (a ``ShearConfig``)."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """SB3's contract: ``(action, state)``; the controller keeps its own memory, so ``state`` passes through."""
        return self.act(observation), state


def play(controller: Any, env: Any, obs: np.ndarray, load_N: float, *,
         on_step: Callable[[np.ndarray, dict], None] | None = None, max_steps: int | None = None,
         prepared: bool = False,
         on_decision: Callable[[np.ndarray, np.ndarray], None] | None = None) -> tuple[float, int, dict]:
    """Run ``controller`` on ``env`` from ``obs`` (the reset's observation) until the episode ends (or ``max_steps``):
    ``bind`` (if it ``needs_env``) and ``reset(load_N, env.config)`` first unless ``prepared``;
    ``on_decision(obs, action)`` after each decision, before the env steps (the env still in the state decided on:
    where a study reads the truth the controller did not see); ``on_step(action, info)`` after each step. Returns
    (return, steps, last info)."""
    if not prepared:
        if getattr(controller, "needs_env", False):
            controller.bind(env)
        controller.reset(load_N, env.unwrapped.config)
    total, steps = 0.0, 0
    while True:
        action = np.asarray(controller.act(obs), dtype=np.float32)
        if on_decision is not None:
            on_decision(obs, action)
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        steps += 1
        if on_step is not None:
            on_step(action, info)
        if terminated or truncated or (max_steps is not None and steps >= max_steps):
            return total, steps, info
