"""One function evaluates every v0 controller: run it on TriPlanarShear-v0 at a load level through the one episode loop\n(:func:`agents.controller_base.play`), measure the mimicry."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.triplanar_shear import ShearConfig, TriPlanarShearEnv, make_config

from .controller_base import Controller, play


@dataclass(frozen=True)
class EpisodeResult:
    """One controlled test. ``mimicry_error_mm``: travel-averaged horizontal distance (mean over the contact points)
    between the block and the hydrostatic reference at the same travel, for a successful test (8 cm reached); NaN
    for a failed one, so that no failure is ever averaged into a mimicry error (averaged over the travel it reached,
    a test arrested at 0 mm would score 0.002 mm). ``mimicry_error_reached_mm`` is the same average over whatever
    travel was reached, for diagnosis only. :mod:`agents.heldout` summarises with success rate, error over successes
    and a score."""

    controller: str
    load_N: float
    seed: int | None
    mimicry_error_mm: float
    reason: str
    success: bool
    travel_m: float
    episode_return: float
    steps: int
    duration_s: float
    contact_points: np.ndarray  # (steps + 1, 3, 3), from the first observation
    reference: np.ndarray       # (REFERENCE_POINTS, 3, 3)
    actions: np.ndarray         # (steps, 2)
    thrust_N: np.ndarray        # (steps,) thrust command of each period
    offset_m: np.ndarray        # (steps,) tip offset at the end of each period
    mimicry_error_reached_mm: float = float("nan")


def make_env(controller: Controller, load_N: float, env_kwargs: dict[str, Any] | None = None) -> TriPlanarShearEnv:
    config = make_config(ShearConfig(load_N=load_N), **{**(env_kwargs or {}), **controller.env_overrides})
    return TriPlanarShearEnv(config=config)


def evaluate(controller: Controller, load_N: float, *, seed: int | None = 0,
             env_kwargs: dict[str, Any] | None = None) -> EpisodeResult:
    """Run ``controller`` for one episode at ``load_N`` through the one episode loop
    (:func:`agents.controller_base.play`; the env is deterministic for fixed friction; ``seed`` matters with friction
    noise in ``env_kwargs``)."""
    env = make_env(controller, load_N, env_kwargs)
    obs, _ = env.reset(seed=seed)
    cps, actions, thrust, offset = [env.contact_points()], [], [], []

    def record(action: np.ndarray, info: dict) -> None:
        actions.append(action)
        thrust.append(info["thrust_N"])
        offset.append(info["tip_offset_m"])
        cps.append(env.contact_points())

    total, steps, info = play(controller, env, obs, load_N, on_step=record)
    success = bool(info["is_success"])
    return EpisodeResult(controller.name, float(load_N), seed,
                         info["mimicry_error_mm"] if success else float("nan"), info["reason"],
                         bool(info["is_success"]), info["travel_m"], total, len(actions), info["time_s"],
                         np.array(cps), env.reference_path.copy(), np.array(actions), np.array(thrust),
                         np.array(offset), info["mimicry_error_mm"])
