"""Controllers for TriPlanarShear-v0 (:class:`agents.controller_base.Controller`s; ``docs/actuator-study.md``).

A controller may need hardware different from the default bench (``env_overrides``, e.g. a teflon tip) and the
task's scaling (``reset(load_N, config)``: thrust and offset ranges); :func:`agents.evaluation.evaluate` does both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from envs.core import (OBS_FACE, OBS_LOAD, OBS_OFFSET, OBS_POS, OBS_VEL, ShearConfig)
from triplanar import kernel as K
from triplanar.model import Loading, Model

from .controller_base import Controller

__all__ = ["Controller", "LowFrictionTip", "MomentMatching", "SteelTip", "TrackingTip"]


@dataclass
class _Scaled(Controller):
    """Physical commands to actions for a given :class:`ShearConfig`."""

    config: ShearConfig = field(default_factory=ShearConfig)

    def reset(self, load_N: float, config: ShearConfig) -> None:
        self.config = config

    def setup(self, config: ShearConfig) -> None:
        """Deprecated: ``reset(load_N, config)`` (the load level is not used here)."""
        self.reset(0.0, config)

    def action(self, thrust_N: float, load_N: float, offset_m: float) -> np.ndarray:
        a0 = 2.0 * thrust_N / (self.config.thrust_scale * load_N) - 1.0
        a1 = offset_m / self.config.offset_range_m
        return np.clip(np.array([a0, a1], dtype=np.float32), -1.0, 1.0)


@dataclass
class SteelTip(_Scaled):
    """The laboratory today (case A): constant thrust at the load level, steel tip fixed on the centreline."""

    name: str = "steel tip"
    env_overrides: dict[str, Any] = field(default_factory=dict)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.action(obs[OBS_LOAD], obs[OBS_LOAD], self.config.tip_offset_m)


@dataclass
class LowFrictionTip(SteelTip):
    """A low-friction tip (teflon ~3 degrees, graphite...) fixed on the centreline, constant thrust."""

    phi_deg: float = 3.0
    name: str = "teflon tip"

    def __post_init__(self) -> None:
        self.env_overrides = {"tip_friction_deg": self.phi_deg}
        if self.name == "teflon tip" and self.phi_deg != 3.0:
            self.name = f"{self.phi_deg:g} deg tip"


@dataclass
class TrackingTip(_Scaled):
    """Steel tip on a stage that follows the aft-face centreline, so the tip does not slip sideways on the face.

    The load point sits ``k3`` along g3 from the centreline point P_CL (observation 20); the stage is commanded to
    ``u - k3`` plus the face's lateral motion over one control period (CP1 is on the aft face: its lateral velocity,
    observation 11, times dt). Constant thrust at the load level.
    """

    name: str = "tracking tip"
    env_overrides: dict[str, Any] = field(default_factory=dict)

    def act(self, obs: np.ndarray) -> np.ndarray:
        target = obs[OBS_OFFSET] - obs[OBS_FACE + 1] + obs[OBS_VEL + 2] * self.config.dt
        return self.action(obs[OBS_LOAD], obs[OBS_LOAD], target)


@dataclass
class MomentMatching(_Scaled):
    """Model-based: thrust and tip offset such that the actuator's force has the hydrostatic load's e1 component
    and the same moment about the vertical through the mass centre (derivation: ``docs/notes/ideal-bench-study.md``).

    Hydrostatic load: ``F g1`` at the body-fixed ``P_CL``, yaw moment ``M_C = F (r_3 g1_1 - r_1 g1_3)`` with
    ``r = P_CL - C``. Actuator: ``T e1`` on the tip line ``x3 = P0_CL,3 + u`` plus the lateral end friction ``f3`` at
    the load point (lever ``l = C_1 - x1_L`` about the mass centre), yaw moment ``T (x3_L - C_3) + l f3``. With
    ``T = F g1_1`` the moments are equal for ``u = u* - l f3 / T``, where the frictionless solution is
    ``u* = P_CL,3 - P0_CL,3 + l g1_3 / g1_1``. The end friction is kinetic, ``f3 = -T g1_1 tan(phi_EF) sign(s)``, with
    the lateral slip ``s = v_face - du/dt`` that the command itself implies (stage velocity ``clip((u - u_now) / dt)``);
    ``u`` is found by fixed-point passes from ``u*`` (``passes``, 2). The pose (g1, C, P_CL) comes from the observed
    contact points and the specimen's geometry (the model). ``friction_compensation=False`` uses ``u*``.
    """

    name: str = "moment matching"
    env_overrides: dict[str, Any] = field(default_factory=dict)
    friction_compensation: bool = True
    passes: int = 2
    _geometry: tuple | None = None

    def reset(self, load_N: float, config: ShearConfig) -> None:
        super().reset(load_N, config)
        specimen, foundation = config.base_specimen()
        model = Model(Loading(1.0, "actuator", config.end_friction, config.tip_offset_m), specimen, foundation)
        p = model.kernel_params()
        y = model.initial_state()
        rot = np.empty((3, 3))
        K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], rot)
        cps = np.empty((3, 3))
        K.contact_points(y, p, cps)
        com_b = rot.T @ (y[K.S_R:K.S_R + 3] - cps[0])   # body frame from CP1: g1 = CP1->CP2, g2 = normal
        pcl_b = rot.T @ (specimen.load_point_world - cps[0])
        phi = self.env_overrides.get("tip_friction_deg", specimen.tip_friction_deg)
        tan_ef = math.tan(math.radians(phi)) if config.end_friction else 0.0
        self._geometry = (cps.copy(), com_b, pcl_b, specimen.load_point_world.copy(), tan_ef)

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self._geometry is None:
            self.reset(0.0, self.config)
        rest, com_b, pcl_b, p0, tan_ef = self._geometry
        cps = rest + obs[OBS_POS:OBS_POS + 9].reshape(3, 3)
        g1 = cps[1] - cps[0]
        g1 /= np.linalg.norm(g1)
        g2 = np.cross(cps[1] - cps[0], cps[2] - cps[0])
        g2 /= np.linalg.norm(g2)
        frame = np.column_stack([g1, g2, np.cross(g1, g2)])
        com = cps[0] + frame @ com_b
        pcl = cps[0] + frame @ pcl_b
        load = float(obs[OBS_LOAD])
        thrust = load * g1[0]
        lever = com[0] - pcl[0]
        u_star = pcl[2] - p0[2] + lever * g1[2] / g1[0]
        offset = u_star
        if self.friction_compensation and tan_ef > 0:
            u, v_face = float(obs[OBS_OFFSET]), float(obs[OBS_VEL + 2])
            dt, v_max = self.config.dt, self.config.stage_speed_m_s
            for _ in range(self.passes):
                slip = v_face - min(max((offset - u) / dt, -v_max), v_max)
                if abs(slip) < 1e-4:  # the tip moves with the face: static friction, no moment assumed
                    break
                f3 = -thrust * g1[0] * tan_ef * math.copysign(1.0, slip)
                offset = u_star - lever * f3 / thrust
        return self.action(thrust, load, offset)
