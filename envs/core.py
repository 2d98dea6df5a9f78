"""The core of the TriPlanarShear environments: the task's configuration, episode draws and their cached starting
states, and the compiled control step (physics, observation, reward terms, termination and the one truncation).

The physics is the compiled kernel of :mod:`triplanar.kernel` (the one right-hand side of the model of Galic,
Glaser & Goodman 2008), stepped at a fixed RK4 step; this module maps actions into the kernel's parameters and
reads observations, rewards and terminations out of its state, as Gymnasium's MuJoCo environments do. The versioned
envs are thin classes over it (:mod:`envs.triplanar_shear`: v0, :mod:`envs.triplanar_shear_v1`: v1, both through
:class:`envs.base.ShearEnvBase`); :mod:`envs.vector` and :mod:`envs.vector_v1` run the same compiled step over N
environments.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from gymnasium import spaces
from numba import njit

from triplanar import PAPER_LOADS_N, driver, kernel as K, stepping
from triplanar.layout import Layout
from triplanar.outcome import RUNNING, TIME_LIMIT, TRAVEL, Outcome
from triplanar.model import Loading, Model, paper_model
from triplanar.simulate import SLOW_SPEED_M_S, simulate
from triplanar.specimen import Foundation, Specimen, reference
from triplanar.statics import holds, start_motion

# -- layouts (triplanar.layout: offsets follow from the sizes; each is unpacked into plain integers below it,
#    checked by an assert, so that numba freezes them in and tools see the names) --
BOOKKEEPING = Layout("ST_", "N_ST", [  # per environment (float64 array ``st``)
    ("T", 1, "time since the start, s"),
    ("STEP", 1, "control periods so far"),
    ("DPREV", 1, "mean distance to the reference at the last period, mm"),
    ("SPREV", 1, "travel at the last period, m"),
    ("A0", 1, "last thrust action"),
    ("A1", 1, "last offset action"),
    ("LOAD", 1, "load level, N"),
    ("THRUST_MAX", 1, "thrust at action +1, N"),
    ("X1_TARGET", 1, "CP1's x1 at the travel target, m"),
    ("ERR_NUM", 1, "travel-integrated distance, mm m"),
    ("ERR_DEN", 1, "travel so far, m"),
    ("MAX_STEPS", 1, "control periods before truncation"),
    ("CP_REST", 9, "contact points at rest (world), row-major CP1..CP3")])
(ST_T, ST_STEP, ST_DPREV, ST_SPREV, ST_A0, ST_A1, ST_LOAD, ST_THRUST_MAX, ST_X1_TARGET, ST_ERR_NUM, ST_ERR_DEN,
 ST_MAX_STEPS, ST_CP_REST, N_ST) = BOOKKEEPING.constants().values()
assert all(globals()[name] == value for name, value in BOOKKEEPING.constants().items())

CONFIG = Layout("CF_", "N_CF", [(name, 1, doc) for name, doc in (  # shared by a batch (float64 array ``cfg``)
    ("DT", "control period, s"), ("H", "RK4 step, s"), ("STAGE", "stage speed limit, m/s"),
    ("RANGE", "offset range, m"), ("TRAVEL", "travel target, m"), ("RATE", "action-rate coefficient"),
    ("FAIL", "failure penalty, mm"), ("WEIGHT", "0: travel-weighted reward, 1: per step"),
    ("SLOW", "speed below which arrest is checked, m/s"), ("ENERGY_TOL", "energy balance tolerance, J"))])
(CF_DT, CF_H, CF_STAGE, CF_RANGE, CF_TRAVEL, CF_RATE,
 CF_FAIL, CF_WEIGHT, CF_SLOW, CF_ENERGY_TOL, N_CF) = CONFIG.constants().values()
assert all(globals()[name] == value for name, value in CONFIG.constants().items())

# info terms (float64 array ``inf``): slot name and, for those reported, the ``info`` key
_INFO = (("REWARD", None), ("R_DIST", "reward_distance"), ("R_RATE", "reward_action_rate"),
         ("R_TERM", "reward_termination"), ("DIST", "distance_mm"), ("ERR", "mimicry_error_mm"),
         ("TRAVEL", "travel_m"), ("THRUST", "thrust_N"), ("OFFSET_CMD", "offset_command_m"), ("OFFSET", "tip_offset_m"),
         ("UDOT", "stage_velocity_m_s"), ("TIME", "time_s"), ("LOAD", "load_N"), ("TRUNC", None),
         ("FALLBACK", "adaptive_steps"))
INFO = Layout("IN_", "N_INFO", [(name, 1, key or "") for name, key in _INFO])
(IN_REWARD, IN_R_DIST, IN_R_RATE, IN_R_TERM, IN_DIST, IN_ERR, IN_TRAVEL, IN_THRUST, IN_OFFSET_CMD, IN_OFFSET,
 IN_UDOT, IN_TIME, IN_LOAD, IN_TRUNC, IN_FALLBACK, N_INFO) = INFO.constants().values()
assert all(globals()[name] == value for name, value in INFO.constants().items())
INFO_KEYS = tuple(key for _, key in _INFO if key)
INFO_SLOTS = tuple(INFO.fields[name].offset for name, key in _INFO if key)

# observation: field, size, bound (values are clipped to +-bound), meaning (the class docstring has the table)
_OBS = (("POS", 9, 0.5, "contact points' displacement from rest, m"), ("VEL", 9, 5.0, "their velocity, m/s"),
        ("OFFSET", 1, 0.5, "tip offset, m"), ("FACE", 2, 0.5, "load point on the aft face from P_CL, m"),
        ("LOAD", 1, 1000.0, "load level, N"), ("REF", 9, 0.5, "hydrostatic reference displacement, m"),
        ("PREV", 2, 1.0, "previous action"), ("TIME", 1, 100.0, "time, s"))
OBSERVATION = Layout("OBS_", "OBS_DIM", [(name, size, doc) for name, size, _, doc in _OBS])
(OBS_POS, OBS_VEL, OBS_OFFSET, OBS_FACE, OBS_LOAD,
 OBS_REF, OBS_PREV, OBS_TIME, OBS_DIM) = OBSERVATION.constants().values()
assert all(globals()[name] == value for name, value in OBSERVATION.constants().items())
OBS_HIGH = np.concatenate([np.full(size, bound) for _, size, bound, _ in _OBS])
REFERENCE_POINTS = 161  # hydrostatic reference sampled every travel_m / 160 (0.5 mm by default)


@dataclass(frozen=True)
class ShearConfig:
    """Everything that defines the task (all are ``gym.make`` keyword arguments).

    Loads: ``load_N`` fixes the load level; otherwise each reset draws it uniformly from ``load_range`` if given,
    else from ``load_levels`` (the paper's 12). Friction noise draws each episode's contact friction angles
    (``friction_noise_deg``, each of the three) and tip friction (``tip_friction_noise_deg``) uniformly within
    +- the given half-width around the specimen's values.
    """

    load_N: float | None = None
    load_levels: tuple[float, ...] = PAPER_LOADS_N
    load_range: tuple[float, float] | None = None
    control_hz: float = 200.0
    substeps: int = 1
    thrust_scale: float = 2.0
    offset_range_m: float = 0.02
    stage_speed_m_s: float = 0.5
    tip_offset_m: float = 0.0
    end_friction: bool = True
    tip_friction_deg: float | None = None
    friction_noise_deg: float = 0.0
    tip_friction_noise_deg: float = 0.0
    travel_m: float = 0.08
    time_limit_s: float = 2.0
    energy_tol_J: float = 1e-8
    action_rate_coef: float = 0.005
    failure_penalty_mm: float = 50.0
    reward_weighting: str = "travel"
    specimen: Specimen | None = None
    foundation: Foundation | None = None

    def validate(self) -> None:
        positive = {"control_hz": self.control_hz, "thrust_scale": self.thrust_scale,
                    "offset_range_m": self.offset_range_m, "stage_speed_m_s": self.stage_speed_m_s,
                    "travel_m": self.travel_m, "time_limit_s": self.time_limit_s}
        for name, value in positive.items():
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        if int(self.substeps) != self.substeps or self.substeps < 1:
            raise ValueError(f"substeps must be a positive integer, got {self.substeps}")
        for name in ("action_rate_coef", "failure_penalty_mm", "friction_noise_deg", "tip_friction_noise_deg",
                     "energy_tol_J"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if abs(self.tip_offset_m) > self.offset_range_m:
            raise ValueError(f"tip_offset_m {self.tip_offset_m} lies outside +-offset_range_m {self.offset_range_m}")
        if self.reward_weighting not in ("travel", "step"):
            raise ValueError(f"reward_weighting must be 'travel' or 'step', got {self.reward_weighting!r}")
        if self.load_N is None and self.load_range is None and not self.load_levels:
            raise ValueError("give load_N, load_range or a non-empty load_levels")
        if self.load_range is not None and not 0 < self.load_range[0] <= self.load_range[1]:
            raise ValueError(f"load_range must be (low, high) with 0 < low <= high, got {self.load_range}")
        # (checked whether or not a reset uses them: v1's randomize draws its own loads, and a bad value given
        # with it would otherwise pass silently)
        if self.load_N is not None and not (_real(self.load_N) and self.load_N > 0):
            raise ValueError(f"load_N must be a positive number, got {self.load_N!r}")
        if not (isinstance(self.load_levels, (tuple, list, np.ndarray))
                and all(_real(v) and v > 0 for v in self.load_levels)):
            raise ValueError(f"load_levels must be a sequence of positive loads in N, got {self.load_levels!r}")

    @property
    def agent_steps(self) -> int:
        """An episode's steps before its truncation (the first control period runs in reset): 399 at 2 s, 200 Hz."""
        return round(self.time_limit_s * self.control_hz) - 1

    @property
    def dt(self) -> float:
        return 1.0 / self.control_hz

    def base_specimen(self) -> tuple[Specimen, Foundation]:
        ref_specimen, ref_foundation = reference()
        specimen = self.specimen or ref_specimen
        if self.tip_friction_deg is not None:
            specimen = replace(specimen, tip_friction_deg=float(self.tip_friction_deg))
        return specimen, self.foundation or ref_foundation

    def packed(self) -> np.ndarray:
        """The numeric configuration for the compiled step (layout ``CF_*``)."""
        cfg = np.zeros(N_CF)
        cfg[CF_DT], cfg[CF_H] = self.dt, self.dt / self.substeps
        cfg[CF_STAGE], cfg[CF_RANGE], cfg[CF_TRAVEL] = self.stage_speed_m_s, self.offset_range_m, self.travel_m
        cfg[CF_RATE], cfg[CF_FAIL] = self.action_rate_coef, self.failure_penalty_mm
        cfg[CF_WEIGHT] = 0.0 if self.reward_weighting == "travel" else 1.0
        cfg[CF_SLOW] = SLOW_SPEED_M_S
        cfg[CF_ENERGY_TOL] = self.energy_tol_J
        return cfg


def make_config(config: ShearConfig | None = None, **kwargs: Any) -> ShearConfig:
    config = replace(config or ShearConfig(), **kwargs)
    if isinstance(config.load_levels, list):
        config = replace(config, load_levels=tuple(config.load_levels))
    config.validate()
    return config


# -- episode draws and their cached starting states ---------------------------------------------------

@dataclass(frozen=True)
class EpisodeDraw:
    """What a reset draws: the load level and the friction angles of this episode."""

    load_N: float
    friction_deg: tuple[float, float, float]
    tip_friction_deg: float


def draw_episode(rng: np.random.Generator, config: ShearConfig, specimen: Specimen,
                 options: dict[str, Any] | None) -> EpisodeDraw:
    """The one place a reset consumes randomness (single and vector envs call it identically); ``specimen`` is
    :meth:`ShearConfig.base_specimen`'s."""
    if not options and config.load_N is not None and config.friction_noise_deg == 0 \
            and config.tip_friction_noise_deg == 0:
        return EpisodeDraw(float(config.load_N), specimen.friction_deg, specimen.tip_friction_deg)
    options = dict(options or {})
    unknown = set(options) - {"load_N", "load_range", "load_levels", "friction_noise_deg", "tip_friction_noise_deg"}
    if unknown:
        raise ValueError(f"unknown reset options {sorted(unknown)}")
    _check_reset_options(options)
    load = options.get("load_N", config.load_N if "load_range" not in options and "load_levels" not in options
                       else None)
    load_range = options.get("load_range", config.load_range if "load_levels" not in options else None)
    levels = tuple(options.get("load_levels", config.load_levels))
    if load is None:
        load = rng.uniform(*load_range) if load_range is not None else levels[int(rng.integers(len(levels)))]
    friction = specimen.friction_deg
    noise = float(options.get("friction_noise_deg", config.friction_noise_deg))
    if noise > 0:
        friction = tuple(float(f) for f in np.asarray(friction) + rng.uniform(-noise, noise, 3))
    tip = specimen.tip_friction_deg
    tip_noise = float(options.get("tip_friction_noise_deg", config.tip_friction_noise_deg))
    if tip_noise > 0:
        tip = max(0.0, tip + float(rng.uniform(-tip_noise, tip_noise)))
    return EpisodeDraw(float(load), tuple(friction), float(tip))


def _real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)) \
        and math.isfinite(value)


def _check_reset_options(options: dict[str, Any]) -> None:
    """A ValueError naming the reset option whose value cannot be used (instead of a numpy error or silence)."""
    for name in ("friction_noise_deg", "tip_friction_noise_deg"):
        if name in options and not (_real(options[name]) and options[name] >= 0):
            raise ValueError(f"reset option {name} must be a finite number >= 0, got {options[name]!r}")
    if "load_N" in options and options["load_N"] is not None and not (_real(options["load_N"])
                                                                       and options["load_N"] > 0):
        raise ValueError(f"reset option load_N must be a positive number, got {options['load_N']!r}")
    if "load_range" in options and options["load_range"] is not None:
        value = options["load_range"]
        if not (isinstance(value, (tuple, list, np.ndarray)) and len(value) == 2 and all(_real(v) for v in value)
                and 0 < value[0] <= value[1]):
            raise ValueError(f"reset option load_range must be (low, high) with 0 < low <= high, got {value!r}")
    if "load_levels" in options:
        value = options["load_levels"]
        if not (isinstance(value, (tuple, list, np.ndarray)) and len(value) > 0
                and all(_real(v) and v > 0 for v in value)):
            raise ValueError(f"reset option load_levels must be a non-empty sequence of positive loads, got {value!r}")


def check_action(action: Any) -> np.ndarray:
    """``action`` as an array of 2 finite real numbers, or a TypeError/ValueError that names it (a NaN would
    otherwise propagate into the state; a wrong shape would be broadcast). Values outside [-1, 1] are clipped
    by the step, as documented."""
    if type(action) is np.ndarray and action.shape == (2,) and action.dtype.kind == "f":
        # the common case, checked without numpy's reductions (they cost microseconds per step)
        if math.isfinite(action[0]) and math.isfinite(action[1]):
            return action
        raise ValueError(f"action must be finite, got {action!r}")
    if action is None or isinstance(action, (str, bytes)):
        raise TypeError(f"action must be 2 real numbers (thrust, lateral offset) in [-1, 1], got {action!r}")
    try:
        arr = np.asarray(action)
    except (TypeError, ValueError) as err:
        raise TypeError(f"action must be 2 real numbers (thrust, lateral offset) in [-1, 1], got {action!r} "
                        f"({err})") from None
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"action must be 2 real numbers (thrust, lateral offset) in [-1, 1], got {action!r} "
                        f"(dtype {arr.dtype})")
    if arr.shape != (2,):
        raise ValueError(f"action must have shape (2,) (thrust, lateral offset), got shape {arr.shape}: {action!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"action must be finite, got {action!r}")
    return arr


def check_actions(actions: Any, num_envs: int) -> np.ndarray:
    """The vector env's ``actions`` as a (num_envs, 2) array of finite real numbers, or a named error."""
    if actions is None or isinstance(actions, (str, bytes)):
        raise TypeError(f"actions must be a ({num_envs}, 2) array of real numbers, got {actions!r}")
    try:
        arr = np.asarray(actions)
    except (TypeError, ValueError) as err:
        raise TypeError(f"actions must be a ({num_envs}, 2) array of real numbers ({err})") from None
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"actions must be a ({num_envs}, 2) array of real numbers, got dtype {arr.dtype}")
    if arr.shape != (num_envs, 2):
        raise ValueError(f"actions must have shape ({num_envs}, 2), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
        raise ValueError(f"actions must be finite, got {arr[bad].tolist()} for env {bad}")
    return arr


@dataclass
class EpisodeStart:
    """A cached starting state: the block after the first control period at the load level, and the
    hydrostatic reference path (contact-point displacements from rest, ``REFERENCE_POINTS`` x 9, by travel)."""

    key: tuple
    model: Model
    y: np.ndarray
    p: np.ndarray
    modes: np.ndarray
    armed: np.ndarray
    st: np.ndarray
    reference: np.ndarray
    reference_status: str
    obs: np.ndarray
    inf: np.ndarray


class StartError(ValueError):
    """The block cannot start: friction holds it at rest under the load level."""


class StartCache:
    """Starting states by specimen, draw and configuration, computed once each and kept (the ``size`` most recently
    used). Each env owns one (a reset at a load level it has run before finds its start here); pass one to
    :func:`episode_start` to share it among the callers that hold it. No cache is global: what an env computes is
    its own."""

    def __init__(self, size: int = 2048):
        self.size = int(size)
        self.entries: OrderedDict[tuple, EpisodeStart] = OrderedDict()

    def get(self, key: tuple) -> EpisodeStart | None:
        entry = self.entries.get(key)
        if entry is not None:
            self.entries.move_to_end(key)
        return entry

    def put(self, key: tuple, entry: EpisodeStart) -> None:
        self.entries[key] = entry
        if len(self.entries) > self.size:
            self.entries.popitem(last=False)


def specimen_key(specimen: Specimen, foundation: Foundation) -> tuple:
    arrays = (specimen.contact_points_m, specimen.mass_centre_m, specimen.inertia_kg_m2, foundation.normals)
    return tuple(np.concatenate([np.ravel(a) for a in arrays]).astype(float).tolist()) + (
        specimen.mass_kg, specimen.load_point_A_m, specimen.load_point_B_m)


def episode_start(config: ShearConfig, draw: EpisodeDraw, specimen: Specimen, foundation: Foundation,
                  base_key: tuple | None = None, cache: StartCache | None = None, *,
                  reference: bool = True) -> EpisodeStart:
    """The starting state for ``draw`` (StartError if the block cannot start), from ``cache`` if it holds it, else
    computed (and kept there).

    ``specimen`` and ``foundation`` are :meth:`ShearConfig.base_specimen`'s; ``base_key`` their
    :func:`specimen_key` (pass it to save recomputing it). ``reference`` False skips the hydrostatic reference run
    (about half of a start's CPU; the reference is zeros, ``reference_status`` ``"none"``): the motion, the contact
    points and the outcome of every later period are the episode's, its rewards and ``OBS_REF`` are not; for a fit
    to measured positions (:meth:`agents.estimator.SpecimenBank._residuals`), never an episode."""
    base_key = base_key if base_key is not None else specimen_key(specimen, foundation)
    key = (base_key, draw, config.end_friction, config.tip_offset_m, config.control_hz, config.substeps,
           config.travel_m, config.thrust_scale, config.offset_range_m, config.stage_speed_m_s, config.time_limit_s)
    key += () if reference else ("no reference",)
    entry = cache.get(key) if cache is not None else None
    if entry is None:
        entry = _compute_start(key, config, draw, specimen, foundation, reference)
        if cache is not None:
            cache.put(key, entry)
    return entry


def _compute_start(key: tuple, config: ShearConfig, draw: EpisodeDraw, specimen: Specimen,
                   foundation: Foundation, reference: bool = True) -> EpisodeStart:
    specimen = replace(specimen, friction_deg=draw.friction_deg, tip_friction_deg=draw.tip_friction_deg)
    model = Model(Loading(draw.load_N, "actuator", config.end_friction, config.tip_offset_m), specimen, foundation)
    model.validate()
    y, p = model.initial_state(), model.kernel_params_cached.copy()
    if holds(model, y, draw.load_N):
        raise StartError(f"friction holds the block at rest under {draw.load_N:g} N (friction {draw.friction_deg}, "
                         f"tip {draw.tip_friction_deg:g} deg, offset {config.tip_offset_m:g} m): it cannot start")
    modes = K.sliding_modes()
    start_motion(p, modes, y)
    cps0 = np.empty((3, 3))
    K.contact_points(y, p, cps0)
    st = np.zeros(N_ST)
    st[ST_LOAD] = draw.load_N
    st[ST_THRUST_MAX] = config.thrust_scale * draw.load_N
    st[ST_X1_TARGET] = cps0[0, 0] + config.travel_m
    st[ST_CP_REST:ST_CP_REST + 9] = cps0.ravel()
    st[ST_MAX_STEPS] = round(config.time_limit_s * config.control_hz)
    st[ST_A0] = 2.0 / config.thrust_scale - 1.0
    st[ST_A1] = config.tip_offset_m / config.offset_range_m
    armed = np.zeros(5, dtype=np.bool_)
    cfg = config.packed()
    obs, inf = np.empty(OBS_DIM), np.empty(N_INFO)
    first = np.array([st[ST_A0], st[ST_A1]])
    # The first period decides whether the test can run (about half of v1's unknown specimens end in it). Its
    # outcome does not depend on the reference path (only the observation and the reward do), so it is run first
    # without one, and the costly hydrostatic reference run is computed only for a start that survives; the period
    # is then run again from the same state with the reference (bitwise what one run with the reference gives).
    before = (y.copy(), p.copy(), modes.copy(), armed.copy(), st.copy())
    code = control_step(y, p, modes, armed, st, np.zeros((REFERENCE_POINTS, 9)), first, cfg, obs, inf,
                        new_workspace())
    if code != RUNNING:
        raise StartError(f"the block's first {1e3 * config.dt:g} ms already ended the test: "
                         f"{Outcome(code).label} (specimen {specimen.name!r}, {draw.load_N:g} N)")
    if not reference:   # (the period just run is the start: only its reward and OBS_REF used the zero reference)
        return EpisodeStart(key, model, y, p, modes, armed, st, np.zeros((REFERENCE_POINTS, 9)), "none", obs, inf)
    y, p, modes, armed, st = before
    reference_run = simulate(paper_model("C", draw.load_N, specimen, foundation), travel_m=config.travel_m)
    grid = np.linspace(0.0, config.travel_m, REFERENCE_POINTS)
    if reference_run.status is Outcome.HELD:
        ref = np.zeros((REFERENCE_POINTS, 9))
    else:  # a reference that stops short of the travel target holds its last position beyond it
        end = reference_run.travel[-1]
        if reference_run.status is Outcome.TRAVEL:
            end = max(end, config.travel_m)  # the run ends at the target (to rounding: 0.0799999999999984)
        reached = grid[grid <= end]
        query = np.minimum(reached, reference_run.travel[-1])
        path = reference_run.resample_by_travel(query) - reference_run.contact_points[0]
        ref = np.concatenate([path, np.repeat(path[-1:], len(grid) - len(reached), axis=0)]).reshape(-1, 9)
    code = control_step(y, p, modes, armed, st, ref, first, cfg, obs, inf, new_workspace())
    return EpisodeStart(key, model, y, p, modes, armed, st, ref, reference_run.status.label, obs, inf)


# -- the compiled control step (shared by the single and the vector env) -------------------------------

# The env's scratch rows, after the driver's (see the note on scratch memory in triplanar.kernel).
WORKSPACE = Layout("EW_", "N_WS_ROWS", [
    ("R", 3, "3x3 rotation matrix"),
    ("CPS", 3, "3x3 contact points"),
    ("ARM", 1, "3-vector: the load point's arm from the mass centre"),
    ("PCL", 1, "3-vector: P_CL's arm from the mass centre"),
    ("AUX", 1, "aux vector of the right-hand side at the period's start"),
    ("DY", 1, "its derivative (unused)"),
    ("NO_T", 1, "recording buffers that stay unused (a control period records nothing)"),
    ("NO_Y", 1, "(rows)")], start=driver.N_WS_ROWS)
(EW_R, EW_CPS, EW_ARM, EW_PCL, EW_AUX, EW_DY, EW_NO_T, EW_NO_Y, N_WS_ROWS) = WORKSPACE.constants().values()
assert all(globals()[name] == value for name, value in WORKSPACE.constants().items())


@njit(cache=True, error_model="numpy")
def new_workspace() -> np.ndarray:
    """Scratch memory for one env's (or one vector env's) control steps."""
    return K.allocate_workspace(np.int64(N_WS_ROWS))  # (not a literal: one compiled version for every module)


@njit(cache=True, inline="always", error_model="numpy")  # (one caller: DEVELOPERS.md, compile time)
def _apply_action(y, p, st, action, cfg, ws) -> None:
    """Thrust and stage velocity for this control period; stuck sites that can no longer stick are released."""
    a0 = min(max(action[0], -1.0), 1.0)
    a1 = min(max(action[1], -1.0), 1.0)
    thrust = 0.5 * (a0 + 1.0) * st[ST_THRUST_MAX]
    u_cmd = a1 * cfg[CF_RANGE]
    udot = min(max((u_cmd - y[K.S_U]) / cfg[CF_DT], -cfg[CF_STAGE]), cfg[CF_STAGE])
    changed_udot = udot != p[K.P_UDOT]
    p[K.P_FCMD] = thrust
    p[K.P_UDOT] = udot
    t = st[ST_T]
    modes = K.modes_of(ws)
    if modes[K.M_TIP_STUCK] != 0.0 and changed_udot:
        # A stage that changes speed cannot carry a stuck face along instantly: the face slips on the tip.
        stepping.apply_mode_event_ws(K.EV_TIP_RELEASE, t, y, p, ws)
    if modes[K.M_STUCK] >= 0.0 or modes[K.M_TIP_STUCK] != 0.0:
        aux = ws[EW_AUX, :K.N_AUX]
        dy = ws[EW_DY, :K.N_STATE]
        K.rhs_ws(t, y, p, dy, aux, ws)
        if modes[K.M_STUCK] >= 0.0 and aux[K.A_STICK] > 0.0:
            stepping.apply_mode_event_ws(K.EV_RELEASE, t, y, p, ws)
            K.rhs_ws(t, y, p, dy, aux, ws)
        if modes[K.M_TIP_STUCK] != 0.0 and aux[K.A_TIP_STICK] > 0.0:
            stepping.apply_mode_event_ws(K.EV_TIP_RELEASE, t, y, p, ws)


@njit(cache=True, inline="always", error_model="numpy")  # (one caller: DEVELOPERS.md, compile time)
def _advance(y, p, armed, st, cfg, inf, ws) -> int:
    """Integrate to the end of the control period or an outcome with the project's one driver
    (:func:`triplanar.driver.drive`: fixed RK4 steps, redone with DOPRI5 where the energy balance is off by more than
    ``energy_tol_J``; arrests decided by the statics LP at the current pose, thrust and tip offset). Returns the
    outcome, ``RUNNING`` when the period ended with the block still moving."""
    count = ws[K.W_COUNT]
    redone = count[K.C_NREDO]
    # Nothing is recorded. Whole workspace rows as the buffers and non-literal arguments give the very signature
    # simulate compiles, so the driver and everything below it are compiled once, not twice.
    no_t, no_rows = ws[EW_NO_T, :1], ws[EW_NO_Y:EW_NO_Y + 1]
    opts = stepping.StepOptions(np.int64(stepping.METHOD_RK4), 0.0, 0.0, (st[ST_STEP] + 1.0) * cfg[CF_DT],
                                st[ST_X1_TARGET], cfg[CF_SLOW], cfg[CF_ENERGY_TOL])
    rec = stepping.Recording(np.bool_(False), no_t, no_rows, no_rows, no_rows, ws[EW_NO_T:EW_NO_T])
    outcome, _, _, _, t = driver.drive(st[ST_T], y, p, armed, cfg[CF_H], opts, rec, np.int64(0), ws)
    st[ST_T] = t
    inf[IN_FALLBACK] = count[K.C_NREDO] - redone
    return RUNNING if outcome == TIME_LIMIT else outcome


@njit(cache=True, error_model="numpy")
def _finish(y, p, st, ref, action, cfg, code, obs, inf, ws) -> None:
    """Observation, reward terms and bookkeeping after a control period that ended with ``code``."""
    st[ST_STEP] += 1.0
    travel = cfg[CF_TRAVEL]
    cps = ws[EW_CPS:EW_CPS + 3, :3]
    K.contact_points_ws(y, p, cps, ws)
    R = ws[EW_R:EW_R + 3, :3]
    K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], R)
    s = cps[0, 0] - st[ST_CP_REST]
    # Hydrostatic reference at the same travel (linear in travel between samples).
    n_ref = ref.shape[0]
    x = min(max(s, 0.0), travel) / travel * (n_ref - 1)
    k = min(int(x), n_ref - 2)
    f = x - k
    dist = 0.0
    for i in range(3):
        dx = 0.0
        dz = 0.0
        for c in range(3):
            disp = cps[i, c] - st[ST_CP_REST + 3 * i + c]
            r = (1.0 - f) * ref[k, 3 * i + c] + f * ref[k + 1, 3 * i + c]
            obs[OBS_POS + 3 * i + c] = disp
            obs[OBS_REF + 3 * i + c] = r
            if c == 0:
                dx = disp - r
            elif c == 2:
                dz = disp - r
        dist += math.sqrt(dx * dx + dz * dz)
    dist *= 1000.0 / 3.0  # mm, mean over the three contact points
    for i in range(3):
        ax = cps[i, 0] - y[K.S_R]
        ay = cps[i, 1] - y[K.S_R + 1]
        az = cps[i, 2] - y[K.S_R + 2]
        w0, w1, w2 = y[K.S_W], y[K.S_W + 1], y[K.S_W + 2]
        obs[OBS_VEL + 3 * i] = y[K.S_V] + w1 * az - w2 * ay
        obs[OBS_VEL + 3 * i + 1] = y[K.S_V + 1] + w2 * ax - w0 * az
        obs[OBS_VEL + 3 * i + 2] = y[K.S_V + 2] + w0 * ay - w1 * ax
    # Load point on the aft face, relative to the centreline point P_CL, along g2 and g3.
    arm = ws[EW_ARM, :3]
    K.load_arm(y, p, R, arm)
    pcl = ws[EW_PCL, :3]
    for c in range(3):
        pcl[c] = R[c, 0] * p[K.P_PCL] + R[c, 1] * p[K.P_PCL + 1] + R[c, 2] * p[K.P_PCL + 2]
    for a in range(2):
        obs[OBS_FACE + a] = (arm[0] - pcl[0]) * R[0, a + 1] + (arm[1] - pcl[1]) * R[1, a + 1] \
            + (arm[2] - pcl[2]) * R[2, a + 1]
    a0 = min(max(action[0], -1.0), 1.0)
    a1 = min(max(action[1], -1.0), 1.0)
    obs[OBS_OFFSET] = y[K.S_U]
    obs[OBS_LOAD] = st[ST_LOAD]
    obs[OBS_PREV] = a0
    obs[OBS_PREV + 1] = a1
    obs[OBS_TIME] = st[ST_T]
    for j in range(OBS_DIM):
        obs[j] = min(max(obs[j], -OBS_HIGH[j]), OBS_HIGH[j])

    ds = abs(s - st[ST_SPREV])
    if cfg[CF_WEIGHT] == 0.0:
        r_dist = -0.5 * (dist + st[ST_DPREV]) * ds / travel
    else:
        r_dist = -dist
    r_rate = -cfg[CF_RATE] * ((a0 - st[ST_A0]) ** 2 + (a1 - st[ST_A1]) ** 2)
    truncated = code == RUNNING and st[ST_STEP] >= st[ST_MAX_STEPS]
    r_term = 0.0
    if (code != RUNNING and code != TRAVEL or truncated) and s < travel:
        r_term = -cfg[CF_FAIL] * (1.0 - max(s, 0.0) / travel)
    st[ST_ERR_NUM] += 0.5 * (dist + st[ST_DPREV]) * ds
    st[ST_ERR_DEN] += ds
    st[ST_DPREV] = dist
    st[ST_SPREV] = s
    st[ST_A0] = a0
    st[ST_A1] = a1
    inf[IN_R_DIST] = r_dist
    inf[IN_R_RATE] = r_rate
    inf[IN_R_TERM] = r_term
    inf[IN_REWARD] = r_dist + r_rate + r_term
    inf[IN_DIST] = dist
    inf[IN_ERR] = st[ST_ERR_NUM] / st[ST_ERR_DEN] if st[ST_ERR_DEN] > 0.0 else dist
    inf[IN_TRAVEL] = s
    inf[IN_THRUST] = p[K.P_FCMD]
    inf[IN_OFFSET_CMD] = a1 * cfg[CF_RANGE]
    inf[IN_OFFSET] = y[K.S_U]
    inf[IN_UDOT] = p[K.P_UDOT]
    inf[IN_TIME] = st[ST_T]
    inf[IN_LOAD] = st[ST_LOAD]
    inf[IN_TRUNC] = 1.0 if truncated else 0.0


@njit(cache=True, error_model="numpy")
def control_step(y, p, modes, armed, st, ref, action, cfg, obs, inf, ws) -> int:
    """One control period: apply ``action``, integrate, observe; returns the outcome code. ``ws`` is a kernel
    workspace (:func:`new_workspace`), scratch only: the stick/slip ``modes`` are put in it for the period and taken
    back."""
    K.modes_of(ws)[:] = modes
    _apply_action(y, p, st, action, cfg, ws)
    code = _advance(y, p, armed, st, cfg, inf, ws)
    modes[:] = K.modes_of(ws)
    _finish(y, p, st, ref, action, cfg, code, obs, inf, ws)
    return code


# The reference terms of the distance: each contact point's x and z (the components _finish's distance uses).
DEVIATION_COLUMNS = np.array([3 * i + c for i in range(3) for c in (0, 2)])
REFERENCE_DEVIATION_DIM = 2 * len(DEVIATION_COLUMNS)


def reference_deviation(obs: np.ndarray, ref: np.ndarray, travel_m: float) -> np.ndarray:
    """The block's deviation from its hydrostatic (case-C) reference and where that reference heads, from state
    observations ``obs`` (``(OBS_DIM,)`` or ``(n, OBS_DIM)``, float64: an env's own, as :func:`control_step` left
    them) and reference paths ``ref`` (``(REFERENCE_POINTS, 9)`` or ``(n, REFERENCE_POINTS, 9)``); ``(..., 12)``:

    * 6 values, mm: CP1 x, CP1 z, CP2 x, ... of the displacement minus the reference at the same travel (the terms
      whose norms, averaged over the three points, are the step's ``distance_mm``: ``_finish`` computes them from the
      same two fields it writes into ``obs``, which agree for displacements within the observation bound of 0.5 m);
    * 6 values, m per m of travel: the reference's slope there (the sample interval ``_finish`` interpolates in).

    The truth of the episode (the reference is simulated from the true specimen): a privileged feature."""
    obs, ref = np.asarray(obs, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    pos = obs[..., OBS_POS + DEVIATION_COLUMNS]
    deviation_mm = (pos - obs[..., OBS_REF + DEVIATION_COLUMNS]) * 1000.0
    n_ref = ref.shape[-2]
    x = np.clip(obs[..., OBS_POS], 0.0, travel_m) / travel_m * (n_ref - 1)   # the travel, as _finish indexes it
    k = np.minimum(x.astype(np.int64), n_ref - 2)
    lower = np.take_along_axis(ref, k[..., None, None], axis=-2)[..., 0, :]
    upper = np.take_along_axis(ref, k[..., None, None] + 1, axis=-2)[..., 0, :]
    slope = (upper - lower)[..., DEVIATION_COLUMNS] * ((n_ref - 1) / travel_m)
    return np.concatenate([deviation_mm, slope], axis=-1)


def contact_points_of(y: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The three contact points (world, 3x3) of state ``y``: what a rendered trace records."""
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    return cps


def load_point_of(t: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray) -> np.ndarray:
    """The instantaneous load point (world) at (t, y): where a rendering draws the tip."""
    aux = np.empty(K.N_AUX)
    K.rhs(t, y, p, modes, np.empty(K.N_STATE), aux)
    return aux[K.A_PL:K.A_PL + 3].copy()


def observation_space() -> spaces.Box:
    high = OBS_HIGH.astype(np.float32)
    return spaces.Box(-high, high, dtype=np.float32)


def action_space() -> spaces.Box:
    return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)


_SLOTS = np.array(INFO_SLOTS)


def reason(code: int, truncated: bool) -> str:
    """``info["reason"]``: the outcome's label (:mod:`triplanar.outcome`) when the episode ended, else ""."""
    if code != RUNNING:
        return Outcome(code).label
    return Outcome.TIME_LIMIT.label if truncated else ""


# info["reason"] by reason code, for the batched envs' arrays (object dtype, as a Gymnasium sync vector env stacks it)
REASON_LABELS = np.array([reason(code, False) if code in Outcome._value2member_map_ else ""
                          for code in range(max(Outcome) + 1)], dtype=object)


def info_dict(inf: np.ndarray, code: int) -> dict[str, Any]:
    info: dict[str, Any] = dict(zip(INFO_KEYS, inf[_SLOTS].tolist()))
    truncated = bool(inf[IN_TRUNC])
    info["reason"] = reason(code, truncated)
    # (the batched envs' integer label of the same: the Outcome value, TIME_LIMIT when truncated, else RUNNING)
    info["reason_code"] = int(code) if code != RUNNING else int(TIME_LIMIT if truncated else RUNNING)
    info["is_success"] = code == TRAVEL
    return info
