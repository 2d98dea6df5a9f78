"""Controllers for ``TriPlanarShear-v1``'s bench observations (``observation_mode="bench"``): they see only the
noisy rangefinders, the load cell, the stage encoder, the load level and time, and know only the nominal specimen.

Each is an :class:`agents.controller_base.Controller`: ``reset(load_N, config)`` (called by the episode loop after
``env.reset``) and ``act(obs) -> action``. ``docs/actuator-study.md`` describes them and how the feedback gains were tuned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from envs.triplanar_shear import ShearConfig
from envs.triplanar_shear_v1 import B_RANGE, B_STAGE
from triplanar import kernel as K
from triplanar.interpolate import linear
from triplanar.model import Loading, Model, paper_model
from triplanar.paths import lateral_dilation
from triplanar.simulate import simulate

from .controller_base import Controller
from .information_bound import InformationBound
from .limit import LimitController
from .mpc import MPCController


@dataclass
class BenchController(Controller):
    """Constant thrust at the load level, tip fixed at ``offset_m`` (the steel, PTFE, rolling or frictionless tip
    of the laboratory today: the tip's friction is the bench's, not the controller's)."""

    name: str = "fixed_tip"
    offset_m: float = 0.0
    config: ShearConfig = field(default_factory=ShearConfig)
    load_N: float = 0.0

    def reset(self, load_N: float, config: ShearConfig) -> None:
        self.config, self.load_N = config, float(load_N)

    def action(self, thrust_N: float, offset_m: float) -> np.ndarray:
        a0 = 2.0 * thrust_N / (self.config.thrust_scale * self.load_N) - 1.0
        a1 = offset_m / self.config.offset_range_m
        return np.clip(np.array([a0, a1], dtype=np.float32), -1.0, 1.0)

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.action(self.load_N, self.offset_m)


def _nominal_geometry(config: ShearConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rest contact points, mass centre and P_CL in the body frame from CP1, and P_CL at rest (world), of the
    nominal specimen (what the laboratory knows)."""
    specimen, foundation = config.base_specimen()
    model = Model(Loading(1.0, "actuator", config.end_friction, 0.0), specimen, foundation)
    p, y = model.kernel_params(), model.initial_state()
    rot = np.empty((3, 3))
    K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], rot)
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    com_b = rot.T @ (y[K.S_R:K.S_R + 3] - cps[0])
    pcl_b = rot.T @ (specimen.load_point_world - cps[0])
    return cps.copy(), com_b, pcl_b, specimen.load_point_world.copy()


def _pose(rest: np.ndarray, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Contact points (world) and the body frame (g1, g2, g3 as columns) from the rangefinders."""
    cps = rest + np.asarray(obs[B_RANGE:B_RANGE + 9], dtype=float).reshape(3, 3)
    g1 = cps[1] - cps[0]
    g1 /= np.linalg.norm(g1)
    g2 = np.cross(cps[1] - cps[0], cps[2] - cps[0])
    g2 /= np.linalg.norm(g2)
    return cps, np.column_stack([g1, g2, np.cross(g1, g2)])


@dataclass
class BenchMomentMatching(BenchController):
    """The moment-matching law of :class:`agents.controllers.MomentMatching` from the rangefinders: thrust
    ``F g1_1`` and the frictionless offset ``u*`` plus the end-friction correction ``-l f3 / T`` for an assumed tip
    friction ``phi_EF`` (``tip_friction_deg``; the adaptive controller estimates it). The face's lateral velocity,
    which sets the slip's sign, is CP1's x3 differenced over ``smoothing`` periods (the rangefinders are noisy)."""

    name: str = "moment_matching"
    tip_friction_deg: float = 8.0
    smoothing: int = 8
    passes: int = 2
    _geometry: tuple | None = None
    _history: list = field(default_factory=list)

    def reset(self, load_N: float, config: ShearConfig) -> None:
        super().reset(load_N, config)
        if self._geometry is None:
            self._geometry = _nominal_geometry(config)
        self._history = []

    def law(self, obs: np.ndarray) -> tuple[float, float, float, float]:
        """(thrust, offset, u*, lever) for the current observation."""
        rest, com_b, pcl_b, p0 = self._geometry
        cps, frame = _pose(rest, obs)
        g1 = frame[:, 0]
        com, pcl = cps[0] + frame @ com_b, cps[0] + frame @ pcl_b
        thrust = self.load_N * g1[0]
        lever = com[0] - pcl[0]
        u_star = pcl[2] - p0[2] + lever * g1[2] / g1[0]
        self._history.append(float(cps[0, 2]))
        tan_ef = math.tan(math.radians(self.tip_friction_deg))
        offset = u_star
        if tan_ef > 0:
            k = min(self.smoothing, len(self._history) - 1)
            v_face = (self._history[-1] - self._history[-1 - k]) / (k * self.config.dt) if k > 0 else 0.0
            u, dt, v_max = float(obs[B_STAGE]), self.config.dt, self.config.stage_speed_m_s
            for _ in range(self.passes):  # as agents.controllers.MomentMatching
                slip = v_face - min(max((offset - u) / dt, -v_max), v_max)
                if abs(slip) < 1e-4:  # the tip moves with the face: static friction, no moment assumed
                    break
                f3 = -thrust * tan_ef * math.copysign(1.0, slip)
                offset = u_star - lever * f3 / thrust
        return thrust, offset, u_star, lever

    def act(self, obs: np.ndarray) -> np.ndarray:
        thrust, offset, _, _ = self.law(obs)
        return self.action(thrust, offset)


@dataclass
class BenchTracking(BenchMomentMatching):
    """The tracking tip of :class:`agents.controllers.TrackingTip` from the rangefinders: constant thrust at the load
    level, the stage commanded to the aft-face centreline (``P_CL``'s lateral position from the measured pose and the
    nominal geometry) plus one period of the face's lateral motion (CP1's x3 differenced, as moment matching does)."""

    name: str = "tracking_tip"

    def act(self, obs: np.ndarray) -> np.ndarray:
        rest, _, pcl_b, p0 = self._geometry
        cps, frame = _pose(rest, obs)
        pcl = cps[0] + frame @ pcl_b
        self._history.append(float(cps[0, 2]))
        k = min(self.smoothing, len(self._history) - 1)
        v_face = (self._history[-1] - self._history[-1 - k]) / (k * self.config.dt) if k > 0 else 0.0
        return self.action(self.load_N, pcl[2] - p0[2] + v_face * self.config.dt)


@lru_cache(maxsize=64)
def nominal_reference(load_N: float, travel_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The nominal specimen's hydrostatic path (case C) at ``load_N``: travel (m) and the mean lateral (x3)
    displacement of the contact points (m), from rest. What the laboratory can compute before the test."""
    run = simulate(paper_model("C", float(load_N)), travel_m=travel_m)
    lateral = lateral_dilation(run.contact_points, run.contact_points[0]).mean(axis=1)
    return np.asarray(run.travel, dtype=float), lateral


@dataclass
class BenchPI(BenchMomentMatching):
    """Feedback: the moment-matching offset (feed-forward, with its end-friction term) plus a PI correction on the block's
    lateral deviation from the nominal hydrostatic path at the measured travel (mean x3 of the three rangefinders,
    so the noise averages), ``u = u_mm - kp e - ki integral(e) dt``. Gains from :func:`agents.heldout.tune_pi`."""

    name: str = "pi_feedback"
    kp: float = 1.0
    ki: float = 0.0
    _integral: float = 0.0

    def reset(self, load_N: float, config: ShearConfig) -> None:
        super().reset(load_N, config)
        self._integral = 0.0
        self._ref = nominal_reference(round(float(load_N), 6), float(config.travel_m))

    def act(self, obs: np.ndarray) -> np.ndarray:
        thrust, offset, _, _ = self.law(obs)
        positions = np.asarray(obs[B_RANGE:B_RANGE + 9], dtype=float).reshape(3, 3)
        travel, lateral = self._ref
        error = float(positions[:, 2].mean() - linear(positions[0, 0], travel, lateral))
        self._integral += error * self.config.dt
        return self.action(thrust, offset - self.kp * error - self.ki * self._integral)


@dataclass
class AdaptiveMomentMatching(BenchMomentMatching):
    """Moment matching with the tip friction estimated online: the block's yaw rate error against the nominal
    path is attributed to a wrong end-friction moment, and ``phi_EF`` is adapted by gradient steps
    ``phi <- phi + gain * e_lateral`` (clipped to 0-20 deg), starting from the steel tip's 8 deg."""

    name: str = "adaptive"
    gain_deg_per_m_s: float = 2000.0

    def reset(self, load_N: float, config: ShearConfig) -> None:
        super().reset(load_N, config)
        self.tip_friction_deg = 8.0
        self._ref = nominal_reference(round(float(load_N), 6), float(config.travel_m))

    def act(self, obs: np.ndarray) -> np.ndarray:
        positions = np.asarray(obs[B_RANGE:B_RANGE + 9], dtype=float).reshape(3, 3)
        travel, lateral = self._ref
        error = float(positions[:, 2].mean() - linear(positions[0, 0], travel, lateral))
        self.tip_friction_deg = min(20.0, max(0.0, self.tip_friction_deg
                                              + self.gain_deg_per_m_s * error * self.config.dt))
        thrust, offset, _, _ = self.law(obs)
        return self.action(thrust, offset)


def _factories() -> dict[str, type]:
    return {"fixed_tip": BenchController, "frictionless_tip": BenchController, "moment_matching": BenchMomentMatching,
            "tracking_tip": BenchTracking, "pi_feedback": BenchPI, "adaptive": AdaptiveMomentMatching,
            "limit": LimitController, "mpc": MPCController, "information_bound": InformationBound}


def controller_names() -> list[str]:
    """The names :func:`make_controller` builds."""
    return sorted(_factories())


def make_controller(name: str, **params: float) -> BenchController:
    """A controller by name (picklable specs for the executor: a name and numbers)."""
    factories = _factories()
    if name not in factories:
        raise ValueError(f"unknown controller {name!r}; choose from {sorted(factories)}")
    controller = factories[name](**params)
    controller.name = name
    return controller
