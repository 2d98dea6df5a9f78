"""``TriPlanarShear-v0``: drive the tri-planar shear test with a servo actuator and make it mimic hydrostatic loading.

A thin versioned class over the env core (:mod:`envs.core`, :class:`envs.base.ShearEnvBase`): the actuator is ideal
(the action goes to the physics as it is), the observation is the exact state, and each reset draws the load level
(and, if asked, friction) of the known reference specimen. :mod:`envs.vector` runs the same step over N envs.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from triplanar.model import Model
from triplanar.outcome import RUNNING

from .base import ShearEnvBase
from .core import (IN_REWARD, IN_TRUNC, ST_T, EpisodeDraw, EpisodeStart, ShearConfig, action_space, check_action,
                   draw_episode, episode_start, info_dict, make_config, observation_space, specimen_key)

__all__ = ["ShearConfig", "TriPlanarShearEnv", "make_config"]


class TriPlanarShearEnv(ShearEnvBase):
    """
    ## Description

    The tri-planar shear test of Galic, Glaser & Goodman (2008): an aluminium block rests on three foundation
    planes and a linear thruster pushes its aft face along ``e1``. In the laboratory the steel load tip rubs on the
    face (end friction, 8 degrees), which bends the block's sliding path away from the one hydrostatic (water)
    pressure would produce: the paper's case C, a frictionless force normal to the aft face at a body-fixed point.
    Here the actuator is a servo: the agent sets the thrust and moves the tip sideways on a rate-limited lateral
    stage, and is rewarded for making the block slide as it would under hydrostatic loading at the same load level.
    The physics is the project's compiled model (:mod:`triplanar.kernel`, stick-slip at the contacts and the tip),
    stepped with fixed RK4 steps.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``, clipped to [-1, 1]. ``step`` refuses anything but 2 finite real numbers with a
    ValueError or TypeError that names the action (NaN, infinity, None, strings, complex or boolean values, other
    shapes), before the state is touched:

    | Num | Action              | Physical value                                                        |
    |-----|---------------------|-----------------------------------------------------------------------|
    | 0   | thrust command      | ``F_T = (a0 + 1) / 2 * thrust_scale * load`` N (default 0 to 2 x load) |
    | 1   | tip offset command  | ``u* = a1 * offset_range_m`` m from the aft-face centreline (default +-20 mm) |

    The stage moves the tip toward ``u*`` at most ``stage_speed_m_s`` (0.5 m/s): each control period its velocity is
    ``clip((u* - u) / dt, -v_max, v_max)``. The tip's lateral velocity enters the slip between tip and aft face, so
    moving the tip makes end friction as it would on the bench. Thrust and stage velocity are held over the period.

    ## Observation Space

    ``Box(34,) float32`` (SI units; values are clipped to the bounds, which a physical episode never reaches):

    | Num   | Observation                                                               | Bound |
    |-------|---------------------------------------------------------------------------|-------|
    | 0-8   | contact points CP1..CP3 displacement from rest (x1, x2, x3 each), m        | 0.5   |
    | 9-17  | contact points CP1..CP3 velocity (x1, x2, x3 each), m/s                    | 5     |
    | 18    | tip offset ``u`` (lateral, +e3, from the centreline at rest), m            | 0.5   |
    | 19-20 | load point on the aft face relative to the centreline point P_CL, along g2 and g3, m | 0.5 |
    | 21    | load level of the episode, N                                               | 1000  |
    | 22-30 | hydrostatic reference (case C): CP1..CP3 displacement from rest at the block's current travel, m | 0.5 |
    | 31-32 | previous action (the action-rate penalty depends on it)                    | 1     |
    | 33    | time since the block started from rest, s                                  | 100   |

    ## Rewards

    With ``d`` the horizontal distance (mm) between each contact point and the reference at the same travel (CP1's
    displacement along e1), averaged over the three contact points, ``s`` the travel, ``S = travel_m`` and ``a`` the
    action, each step gives ``reward = r_distance + r_action_rate + r_termination`` with

    * ``r_distance = -(d_prev + d) / 2 * |s - s_prev| / S`` (``reward_weighting="travel"``, default), so a full episode's
      distance terms sum to minus the travel-averaged mimicry error in mm (trapezoid rule, as the paper compares
      paths by travel, not time); with ``reward_weighting="step"``: ``-d`` every step;
    * ``r_action_rate = -action_rate_coef * |a - a_prev|^2`` (default 0.005);
    * ``r_termination = -failure_penalty_mm * (1 - s / S)`` when the episode ends in anything but success (default
      50 mm: a failed test costs as if the untravelled rest of the path were 50 mm off).

    Every term is in ``info`` (``reward_distance``, ``reward_action_rate``, ``reward_termination``) with
    ``distance_mm``, ``mimicry_error_mm`` (travel-averaged ``d`` so far), ``travel_m``, ``thrust_N``,
    ``offset_command_m``, ``tip_offset_m``, ``stage_velocity_m_s``, ``time_s``, ``load_N``, ``reason``,
    ``reason_code`` (the :class:`triplanar.outcome.Outcome` value, as the batched env's), ``is_success`` and the
    episode's draw (``friction_deg``, ``tip_friction_deg``); reset's ``info`` has the same keys. A return of -1 or
    more (``spec.reward_threshold``) means a mimicry error under the project's 1 mm target.

    ## Starting State

    Each reset draws the load level (``load_N`` fixed, else uniform from ``load_range``, else one of
    ``load_levels``: the paper's 12, 27.8 to 55.6 N) and, if asked, the friction angles. The block rests on the planes
    with the tip at ``tip_offset_m``; the actuator starts the test as the laboratory does, pushing at the load level
    with the stage still, and the first control period (5 ms) runs so. The returned observation is the state after
    it; the policy acts from then on. (Starting from rest costs an LP and a mode search, ~10 ms: doing it once per
    load level and friction draw, cached, makes resets cost microseconds. The first period decides only whether the
    load level can start the block, which the laboratory tests always do.)

    ## Episode End

    ``info["reason"]`` says which, in the project's outcome vocabulary (:class:`triplanar.outcome.Outcome`):

    * terminated, ``travel`` (the success, ``info["is_success"]``): CP1 has travelled ``travel_m`` (8 cm) along e1
      (located exactly within the period);
    * terminated, ``lift_off``: a contact point's normal reaction reached zero;
    * terminated, ``mass_centre_outside``: the mass centre left the contact triangle seen from above (tipping);
    * terminated, ``left_plane``: a contact point crossed onto another plane (CP3 starts where all three meet);
    * terminated, ``arrested``: every contact point came (nearly) to rest and friction holds the block under the
      current command (statics LP, :func:`triplanar.equilibrium.holds`, decided inside the compiled driver,
      :func:`triplanar.driver.drive`, which :func:`triplanar.simulate.simulate` uses too);
    * terminated, ``failed``: the integration failed (singular contact system; not seen in practice);
    * truncated, ``time_limit``: ``time_limit_s`` (2 s) after the start: the env's own and only truncation (the
      registration sets no ``max_episode_steps``; the first period runs in ``reset``, so 399 agent steps at the
      defaults). A ``step`` after the end warns once (as Gymnasium's CartPole); after a ``reset`` that raised,
      ``step`` is refused until a ``reset`` succeeds.

    ## Arguments

    ``gym.make("TriPlanarShear-v0", **kwargs)`` with any :class:`ShearConfig` field: ``load_N``, ``load_levels``,
    ``load_range``, ``control_hz`` (200), ``substeps`` (RK4 steps per control period, 1), ``thrust_scale`` (2),
    ``offset_range_m`` (0.02), ``stage_speed_m_s`` (0.5), ``tip_offset_m`` (0), ``end_friction`` (True),
    ``tip_friction_deg`` (the specimen's, 8), ``friction_noise_deg`` and ``tip_friction_noise_deg`` (0),
    ``travel_m`` (0.08), ``time_limit_s`` (2), ``action_rate_coef``, ``failure_penalty_mm``, ``reward_weighting``,
    ``specimen``/``foundation`` (default the reference specimen), and ``render_mode`` (``"rgb_array"``,
    ``"human"``; ``render_fps`` is the control rate, a frame per period: videos play in real time).
    ``reset(options=...)`` accepts ``load_N``, ``load_range``, ``load_levels``, ``friction_noise_deg``,
    ``tip_friction_noise_deg`` for that episode.

    ## Version History

    * v0: the initial version. Since the project's one outcome vocabulary (:mod:`triplanar.outcome`),
      ``info["reason"]`` says ``travel`` where it said ``success`` and ``arrested`` where it said ``arrest``, and the
      vector env's ``reason_code`` is the :class:`~triplanar.outcome.Outcome` value; dynamics, observations, rewards,
      terminations and truncations are bitwise the same as before. Since the shared env core
      (:class:`envs.base.ShearEnvBase`): the frames are drawn by v1's renderer (Pillow, one per control period) and
      ``render_fps`` is the control rate (a recorded video plays in real time; it was 30).
    * ``TriPlanarShearIdeal-v0``: this env under a name of its own (the ideal bench and the realistic one,
      ``TriPlanarShearRealistic-v0``, are two tasks); ``TriPlanarShear-v0`` makes the same class. Since then: reset
      ``info`` has the step's keys (the start's values) and step ``info`` the draw's (``friction_deg``,
      ``tip_friction_deg``), both ``reason_code``; a warning on ``step`` after the end, ``step`` refused after a failed
      ``reset``; ``load_N`` and ``load_levels`` checked at construction. Rollouts bitwise the same.
    """

    def __init__(self, render_mode: str | None = None, config: ShearConfig | None = None, **kwargs: Any):
        self.config = make_config(config, **kwargs)
        self.action_space = action_space()
        self.observation_space = observation_space()
        self._init_core(render_mode)
        self._base_key = specimen_key(self._specimen, self._foundation)
        self._starts: dict[EpisodeDraw, EpisodeStart] = {}
        self._action = np.zeros(2)
        self._draw_info: dict[str, Any] = {}

    # -- Gymnasium API ---------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self._begin_reset()
        super().reset(seed=seed)
        draw = draw_episode(self.np_random, self.config, self._specimen, options)
        start = self._starts.get(draw)
        if start is None:
            start = episode_start(self.config, draw, self._specimen, self._foundation, self._base_key)
            if len(self._starts) < 64:
                self._starts[draw] = start
        self._load_start(start)
        self._draw_info = {"friction_deg": draw.friction_deg, "tip_friction_deg": draw.tip_friction_deg}
        info = info_dict(self._inf, RUNNING)   # the step's keys (the start's values), and the draw, as step gives
        info.update(self._draw_info, load_N=draw.load_N, time_s=float(self._st[ST_T]))
        return self._obs.astype(np.float32), info

    def step(self, action):
        self._check_step_allowed()
        self._action[:] = check_action(action)
        code = self._control_step(self._action)
        info = info_dict(self._inf, code)
        info.update(self._draw_info)
        return self._obs.astype(np.float32), float(self._inf[IN_REWARD]), code > 0, bool(self._inf[IN_TRUNC]), info

    @property
    def model(self) -> Model:
        """The episode's model (specimen with this episode's friction, actuator at the load level)."""
        if self._start is None:
            raise gym.error.ResetNeeded("call reset() first")
        return self._start.model
