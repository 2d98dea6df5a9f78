"""``TriPlanarShearRealistic-v0`` (first published as ``TriPlanarShear-v1``): the tri-planar shear test on a bench
that could exist (finite servo bandwidths, command latency, noisy sensors, unknown specimens). The physics and the
distance and termination rewards are the ideal bench's compiled control step
(:func:`envs.core.control_step`, through :class:`envs.base.ShearEnvBase`); this module adds the bench between the
agent and that step. :mod:`envs.vector_v1` runs the same over N envs.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields, replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numba import njit

from triplanar import kernel as K
from triplanar.layout import Layout
from triplanar.specimen import Foundation, Plane, Specimen

from .base import ShearEnvBase, ShearState
from .core import (IN_R_DIST, IN_R_TERM, IN_THRUST, IN_TRUNC, OBS_POS, OBS_PREV, ST_LOAD, ST_T, EpisodeDraw,
                   EpisodeStart, ShearConfig, StartCache, StartError, check_action, draw_episode, episode_start,
                   info_dict, make_config, observation_space, specimen_key)

# (This module's compiled functions read the kernel's and v0's layouts; envs/__init__.py drops the package's numba
# cache when those change.)

# Bench observation ("bench" mode): field, size, bound, meaning.
_BENCH_OBS = (("RANGE", 9, 0.5, "rangefinders: CP1..CP3 displacement from rest (x1, x2, x3 each) + noise, m"),
              ("THRUST", 1, 1000.0, "load cell: thrust at the period's end, N"),
              ("STAGE", 1, 0.5, "stage encoder: tip offset, m"),
              ("LOAD", 1, 1000.0, "load level of the episode, N"),
              ("TIME", 1, 100.0, "time since the start, s"),
              ("PREV", 2, 1.0, "previous action"))
BENCH_OBSERVATION = Layout("B_", "BENCH_OBS_DIM", [(name, size, doc) for name, size, _, doc in _BENCH_OBS])
(B_RANGE, B_THRUST, B_STAGE, B_LOAD, B_TIME, B_PREV, BENCH_OBS_DIM) = BENCH_OBSERVATION.constants().values()
assert all(globals()[name] == value for name, value in BENCH_OBSERVATION.constants().items())
BENCH_HIGH = np.concatenate([np.full(size, bound) for _, size, bound, _ in _BENCH_OBS])
BENCH_HIGH.setflags(write=False)

# The bench's constants for the compiled bench step (set once per env from BenchConfig and ShearConfig).
BENCH_CONSTANTS = Layout("BC_", "N_BC", [
    ("THRUST_SCALE", 1, "ShearConfig.thrust_scale"),
    ("RANGE", 1, "ShearConfig.offset_range_m"),
    ("DT", 1, "control period, s"),
    ("STAGE", 3, "stage servo: finite (1/0), tau (s), decay over a period (servo_constants)"),
    ("FORCE", 3, "force loop: the same")])
(BC_THRUST_SCALE, BC_RANGE, BC_DT, BC_STAGE, BC_FORCE, N_BC) = BENCH_CONSTANTS.constants().values()
assert all(globals()[name] == value for name, value in BENCH_CONSTANTS.constants().items())
# The bench's state between steps (the latency queue is an array of its own).
BENCH_STATE = Layout("BS_", "N_BS", [
    ("THRUST", 1, "the force loop's output (the load cell) at the period's end, N"),
    ("PREV", 2, "the agent's previous action, clipped"),
    ("HEAD", 1, "the latency queue's oldest row")])
(BS_THRUST, BS_PREV, BS_HEAD, N_BS) = BENCH_STATE.constants().values()
assert all(globals()[name] == value for name, value in BENCH_STATE.constants().items())



@dataclass(frozen=True)
class BenchRanges:
    """The ranges an unknown specimen is drawn from (:func:`draw_bench`, uniform in each): ``friction_deg``, each
    contact's friction angle +- around the specimen's; ``tip_friction_deg`` (low, high); ``mass``, +- a fraction (the
    inertia tensor scales with it); ``mass_centre_m``, +- on each body axis; ``tilt_deg``, each plane's dip +- (a plane
    dipping less, the horizontal one, gets a dip in [0, tilt_deg] in any direction); ``tilt_direction_deg``, the dipping
    planes' dip direction +-; ``load_N`` (low, high)."""

    friction_deg: float = 2.0
    tip_friction_deg: tuple[float, float] = (3.0, 12.0)
    mass: float = 0.05
    mass_centre_m: float = 0.005
    tilt_deg: float = 0.5
    tilt_direction_deg: float = 5.0
    load_N: tuple[float, float] = (27.8, 55.6)


# v1's unknown specimens (randomize=True): the training ranges; docs/environment.md gives the reasons. Everything that
# draws or bounds a bench imports this object (the held-out and tuning streams, the estimator's prior; the stress set
# widens it, agents.heldout.STRESS_RANGES).
TRAINING_RANGES = BenchRanges()
# (the same numbers under their earlier names, kept for code that imports them)
RANDOM_FRICTION_DEG = TRAINING_RANGES.friction_deg
RANDOM_TIP_FRICTION_DEG = TRAINING_RANGES.tip_friction_deg
RANDOM_MASS = TRAINING_RANGES.mass
RANDOM_MASS_CENTRE_M = TRAINING_RANGES.mass_centre_m
RANDOM_TILT_DEG = TRAINING_RANGES.tilt_deg
RANDOM_TILT_DIRECTION_DEG = TRAINING_RANGES.tilt_direction_deg
RANDOM_LOAD_N = TRAINING_RANGES.load_N
START_ATTEMPTS = 20                 # draws before giving up on a specimen that friction holds at rest


@dataclass(frozen=True)
class BenchConfig:
    """The bench and what the controller sees (v1's own ``gym.make`` arguments; the class docstring of
    :class:`TriPlanarShearV1Env` has the table and the sources of the defaults)."""

    stage_bandwidth_hz: float = 20.0
    thrust_bandwidth_hz: float = 30.0
    latency_s: float = 0.005
    sensor_noise_m: float = 2e-4
    observation_mode: str = "bench"
    randomize: bool = False

    def validate(self, dt: float, time_limit_s: float) -> None:
        """A ValueError naming the first argument that cannot be used, before anything is allocated from it."""
        if not isinstance(self.randomize, (bool, np.bool_)):  # "no" would be truthy
            raise ValueError(f"randomize must be True or False, got {self.randomize!r}")
        for name in ("stage_bandwidth_hz", "thrust_bandwidth_hz"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value > 0 and not math.isnan(value)):
                raise ValueError(f"{name} must be a positive number or math.inf (ideal), got {value!r}")
        for name in ("latency_s", "sensor_noise_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.latency_s > time_limit_s:  # (the latency queue holds latency_s / dt commands)
            raise ValueError(f"latency_s must lie in [0, time_limit_s = {time_limit_s:g} s] (a command delayed "
                             f"longer never acts within the episode), got {self.latency_s!r}")
        periods = self.latency_s / dt
        if abs(periods - round(periods)) > 1e-9:
            raise ValueError(f"latency_s must be a whole number of control periods ({dt:g} s), got {self.latency_s}")
        if self.observation_mode not in ("state", "bench"):
            raise ValueError(f"observation_mode must be 'state' or 'bench', got {self.observation_mode!r}")

    def latency_periods(self, dt: float) -> int:
        return int(round(self.latency_s / dt))


# v1's hardware and observation by default: the one place its defaults are written (the single and the batched env's
# arguments and agents.mpc's known hardware read them here).
DEFAULT_BENCH = BenchConfig()


def servo_constants(bandwidth_hz: float, dt: float) -> tuple[float, float]:
    """``(tau, decay)`` of a first-order lag of bandwidth ``bandwidth_hz`` (finite) over ``dt``."""
    tau = 1.0 / (2.0 * math.pi * bandwidth_hz)
    return tau, math.exp(-dt / tau)


@njit(cache=True, error_model="numpy")
def first_order_response(x: float, target: float, tau: float, decay: float, dt: float) -> tuple[float, float]:
    """Exact response of ``dx/dt = (target - x) / tau`` over ``dt``: (value at the end, mean over the period)."""
    end = target + (x - target) * decay
    mean = target + (x - target) * tau / dt * (1.0 - decay)
    return end, mean


def first_order_step(x: float, target: float, bandwidth_hz: float, dt: float) -> tuple[float, float]:
    """Exact response of ``dx/dt = 2 pi f (target - x)`` over ``dt``: (value at the end, mean over the period)."""
    if math.isinf(bandwidth_hz):
        return target, target
    tau, decay = servo_constants(bandwidth_hz, dt)
    return first_order_response(x, target, tau, decay, dt)


def bench_constants(bench: BenchConfig, config: ShearConfig) -> np.ndarray:
    """The ``BC_*`` vector of an env."""
    bc = np.zeros(N_BC)
    bc[BC_THRUST_SCALE], bc[BC_RANGE], bc[BC_DT] = config.thrust_scale, config.offset_range_m, config.dt
    for slot, bandwidth in ((BC_STAGE, bench.stage_bandwidth_hz), (BC_FORCE, bench.thrust_bandwidth_hz)):
        if math.isfinite(bandwidth):
            bc[slot] = 1.0
            bc[slot + 1], bc[slot + 2] = servo_constants(bandwidth, config.dt)
    return bc


@njit(cache=True, error_model="numpy")
def bench_command(raw: np.ndarray, bc: np.ndarray, bs: np.ndarray, queue: np.ndarray, y: np.ndarray,
                  st: np.ndarray, applied: np.ndarray) -> tuple[float, float]:
    """The bench between the agent's action ``raw`` and v0's step: the action clipped, delayed by the latency
    queue (``queue``, one row per period of latency, oldest at ``bs[BS_HEAD]``), the thrust through the force loop
    and the tip offset through the stage servo. Writes the (thrust, end-of-period tip position) action for v0's step
    into ``applied`` and updates ``bs``; returns the change of the agent's (clipped) action since the previous step,
    for the action-rate reward term. (The env squares it in Python: ``x ** 2`` there is the C library's ``pow``,
    which can differ from the product ``x * x`` that compiled code makes of it in the last bit.)"""
    a0 = min(max(np.float64(raw[0]), -1.0), 1.0)
    a1 = min(max(np.float64(raw[1]), -1.0), 1.0)
    latency = queue.shape[0]
    if latency == 0:
        c0, c1 = a0, a1
    else:
        head = int(bs[BS_HEAD])
        c0, c1 = queue[head, 0], queue[head, 1]
        queue[head, 0], queue[head, 1] = a0, a1
        bs[BS_HEAD] = (head + 1) % latency
    dt = bc[BC_DT]
    thrust_max = bc[BC_THRUST_SCALE] * st[ST_LOAD]
    thrust_cmd = 0.5 * (c0 + 1.0) * thrust_max
    if bc[BC_FORCE] != 0.0:
        bs[BS_THRUST], thrust_mean = first_order_response(bs[BS_THRUST], thrust_cmd, bc[BC_FORCE + 1],
                                                          bc[BC_FORCE + 2], dt)
        # v0's step takes (thrust, end-of-period tip position) as an action; both are convex combinations of
        # values inside the action range, so its clipping leaves them as they are.
        applied[0] = 2.0 * thrust_mean / thrust_max - 1.0
    else:
        bs[BS_THRUST] = thrust_cmd
        applied[0] = c0
    if bc[BC_STAGE] != 0.0:
        u_end, _ = first_order_response(y[K.S_U], c1 * bc[BC_RANGE], bc[BC_STAGE + 1], bc[BC_STAGE + 2], dt)
        applied[1] = u_end / bc[BC_RANGE]
    else:
        applied[1] = c1
    d0, d1 = a0 - bs[BS_PREV], a1 - bs[BS_PREV + 1]
    bs[BS_PREV], bs[BS_PREV + 1] = a0, a1
    return d0, d1


@njit(cache=True, error_model="numpy")
def bench_observation(obs: np.ndarray, noise: np.ndarray, bs: np.ndarray, y: np.ndarray, st: np.ndarray,
                      high: np.ndarray) -> np.ndarray:
    """The bench observation (``B_*``, float32) from v0's observation ``obs`` (its exact positions), the
    rangefinders' ``noise`` (9 values, or none), the bench state and the block's state; clipped to ``high``."""
    out = np.empty(BENCH_OBS_DIM)
    for i in range(9):
        out[B_RANGE + i] = obs[OBS_POS + i]
    if noise.shape[0] > 0:
        for i in range(9):
            out[B_RANGE + i] += noise[i]
    out[B_THRUST] = bs[BS_THRUST]
    out[B_STAGE] = y[K.S_U]
    out[B_LOAD] = st[ST_LOAD]
    out[B_TIME] = st[ST_T]
    out[B_PREV] = bs[BS_PREV]
    out[B_PREV + 1] = bs[BS_PREV + 1]
    result = np.empty(BENCH_OBS_DIM, np.float32)
    for i in range(BENCH_OBS_DIM):
        v = out[i]
        if v < -high[i]:
            v = -high[i]
        elif v > high[i]:
            v = high[i]
        result[i] = np.float32(v)
    return result


@dataclass
class BenchState(ShearState):
    """A v1 episode's whole state: :class:`envs.base.ShearState` and the bench's, its constants ``bc``
    (``BC_*``), state ``bs`` (``BS_*``) and latency ``queue`` (:meth:`TriPlanarShearV1Env.get_state`; the
    model-based controllers predict from it, :mod:`envs.prediction`)."""

    bc: np.ndarray
    bs: np.ndarray
    queue: np.ndarray


@dataclass(frozen=True)
class Bench:
    """One episode's specimen and foundation (the nominal ones, or an unknown specimen's draw)."""

    specimen: Specimen
    foundation: Foundation
    load_N: float

    def info(self) -> dict[str, Any]:
        s, f = self.specimen, self.foundation
        return {"load_N": self.load_N, "friction_deg": tuple(float(v) for v in s.friction_deg),
                "tip_friction_deg": float(s.tip_friction_deg), "mass_kg": float(s.mass_kg),
                "mass_centre_m": tuple(float(v) for v in s.mass_centre_m),
                "plane_dips_deg": tuple(float(p.dip_deg) for p in f.planes)}


def draw_bench(rng: np.random.Generator, specimen: Specimen, foundation: Foundation,
               ranges: BenchRanges = TRAINING_RANGES, label: str = "random") -> Bench:
    """An unknown specimen from ``ranges`` (v1's training ranges by default), uniform, from ``rng``; its name is the
    specimen's with ``(label)``."""
    r = ranges
    friction = tuple(float(v) for v in np.asarray(specimen.friction_deg)
                     + rng.uniform(-r.friction_deg, r.friction_deg, 3))
    tip = float(rng.uniform(*r.tip_friction_deg))
    scale = 1.0 + float(rng.uniform(-r.mass, r.mass))
    centre = np.asarray(specimen.mass_centre_m) + rng.uniform(-r.mass_centre_m, r.mass_centre_m, 3)
    planes = []
    for plane in foundation.planes:
        if plane.dip_deg < r.tilt_deg:  # a (nearly) horizontal plane tilts a little in any direction
            planes.append(Plane(float(rng.uniform(0.0, r.tilt_deg)), float(rng.uniform(0.0, 360.0))))
        else:
            planes.append(Plane(plane.dip_deg + float(rng.uniform(-r.tilt_deg, r.tilt_deg)),
                                plane.dip_direction_deg + float(rng.uniform(-r.tilt_direction_deg,
                                                                            r.tilt_direction_deg))))
    load = float(rng.uniform(*r.load_N))
    return unknown_bench(specimen, friction, tip, scale, centre, tuple(planes), load, f"{specimen.name} ({label})")


def unknown_bench(specimen: Specimen, friction_deg: tuple[float, ...], tip_friction_deg: float, mass_scale: float,
                  mass_centre_m: np.ndarray, planes: tuple[Plane, ...], load_N: float, name: str) -> Bench:
    """``specimen`` with the given unknowns (the parameters :func:`draw_bench` draws) on a foundation of ``planes``.
    The block sits on the tilted planes: each contact point's rest height follows its plane (a fraction of a mm,
    like a machining tolerance of the block); the inertia tensor scales with the mass."""
    points = np.array(specimen.contact_points_m, dtype=float)
    for i, plane in enumerate(planes):
        points[i, 1] = float(plane.height(points[i, 0], points[i, 2]))
    new = replace(specimen, contact_points_m=points, friction_deg=friction_deg, tip_friction_deg=tip_friction_deg,
                  mass_kg=specimen.mass_kg * mass_scale, inertia_kg_m2=np.asarray(specimen.inertia_kg_m2) * mass_scale,
                  mass_centre_m=mass_centre_m, name=name)
    return Bench(new, Foundation(tuple(planes)), load_N)


def draw_bench_for(rng: np.random.Generator, config: ShearConfig, randomize: bool, specimen: Specimen,
                   foundation: Foundation) -> Bench:
    """One episode's bench from ``rng``: an unknown specimen (``randomize``; a ``tip_friction_deg`` given to the env
    is known hardware and is not drawn), else v0's draw (load level, friction noise) of the configured specimen."""
    if randomize:
        bench = draw_bench(rng, specimen, foundation)
        if config.tip_friction_deg is not None:
            bench = replace(bench, specimen=replace(bench.specimen, tip_friction_deg=float(config.tip_friction_deg)))
        return bench
    draw = draw_episode(rng, config, specimen, None)
    return Bench(replace(specimen, friction_deg=draw.friction_deg, tip_friction_deg=draw.tip_friction_deg),
                 foundation, draw.load_N)


def state_observation(obs: np.ndarray, bs: np.ndarray) -> np.ndarray:
    """What ``observation_mode="state"`` observes (in float64, before its float32): the state observation ``obs``
    with the previous action the bench's (``bs``, the command the agent sent, clipped), a copy."""
    out = obs.copy()
    out[OBS_PREV:OBS_PREV + 2] = bs[BS_PREV:BS_PREV + 2]
    return out


def bench_start(config: ShearConfig, bench: Bench, cache: StartCache | None = None, *,
                reference: bool = True) -> EpisodeStart:
    """The start of ``bench`` (:func:`envs.core.episode_start`, kept in ``cache`` if given; StartError if it cannot
    start; ``reference`` False: without the case-C reference, as there)."""
    specimen = bench.specimen
    return episode_start(config, EpisodeDraw(bench.load_N, tuple(specimen.friction_deg),
                                             float(specimen.tip_friction_deg)),
                         specimen, bench.foundation, specimen_key(specimen, bench.foundation), cache,
                         reference=reference)


def can_start(config: ShearConfig, bench: Bench, cache: StartCache | None = None) -> bool:
    """Whether ``bench`` can start under ``config`` (friction does not hold it at rest and its first period does not
    end the test): the check each reset makes, :func:`bench_start`; a laboratory would not run a bench that fails it."""
    try:
        bench_start(config, bench, cache)
    except StartError:
        return False
    return True


def draw_start(rng: np.random.Generator, config: ShearConfig, randomize: bool, specimen: Specimen,
               foundation: Foundation, cache: StartCache | None = None) -> tuple[Bench, EpisodeStart]:
    """What a reset draws from ``rng`` and its start; an unknown specimen that friction holds at rest is drawn
    again (up to ``START_ATTEMPTS`` draws). The single and the batched v1 both call it, so they draw alike."""
    for _ in range(START_ATTEMPTS):
        bench = draw_bench_for(rng, config, randomize, specimen, foundation)
        try:
            return bench, bench_start(config, bench, cache)
        except StartError:
            if not randomize:
                raise
    raise StartError(f"no startable specimen in {START_ATTEMPTS} draws")


def nominal_command(config: ShearConfig) -> np.ndarray:
    """The action of the nominal command: thrust at the load level, the tip at the config's offset (what the bench
    was commanded before the episode, and what ``mpc`` holds before its first decision)."""
    return np.array([2.0 / config.thrust_scale - 1.0, config.tip_offset_m / config.offset_range_m])


def reset_bench_state(config: ShearConfig, start: EpisodeStart, bs: np.ndarray, queue: np.ndarray) -> None:
    """The bench's state at an episode's start: the latency queue full of the starting command (the nominal one),
    the force loop's output the thrust at the first period's end."""
    first = nominal_command(config)
    queue[:] = first
    bs[BS_HEAD] = 0.0
    bs[BS_THRUST] = start.inf[IN_THRUST]
    bs[BS_PREV:BS_PREV + 2] = first


def bench_option(options: dict[str, Any] | None) -> Bench | None:
    """The ``bench`` of v1's reset options (its only one), or a named error."""
    options = dict(options or {})
    bench = options.pop("bench", None)
    if options:
        raise ValueError(f"unknown reset options {sorted(options)} (v1 takes 'bench')")
    if bench is not None and not isinstance(bench, Bench):
        raise TypeError(f"reset option bench must be an envs.triplanar_shear_v1.Bench, got {bench!r}")
    return bench


def observation_space_of(observation_mode: str) -> spaces.Box:
    """One v1 env's observation space in ``observation_mode`` (``"bench"``: ``B_*``; ``"state"``: v0's)."""
    if observation_mode == "state":
        return observation_space()
    high = BENCH_HIGH.astype(np.float32)
    return spaces.Box(-high, high, dtype=np.float32)


def action_rate_reward(coef: float, d0: float, d1: float) -> float:
    """The action-rate term on the agent's actions (``x ** 2`` in Python, the C library's ``pow``: see
    :func:`bench_command`); the single and the batched env both call it, so their rewards are bitwise equal."""
    return -coef * (d0 ** 2 + d1 ** 2)


# Arguments of the batched env only (envs.vector_v1): a single env has no frame stack or start bank.
BATCH_ONLY = ("frame_stack", "start_bank", "bank_reuse")


def refuse_batch_arguments(kwargs: dict[str, Any]) -> None:
    """A named error for a batched-env argument given to the single env (``gym.make``, or ``gym.make_vec`` in sync
    or async mode, which makes single envs), instead of ShearConfig's TypeError."""
    given = [name for name in BATCH_ONLY if name in kwargs]
    if given:
        raise TypeError(f"{', '.join(given)} is an argument of the batched env only: use gym.make_vec(..., "
                        f"vectorization_mode='vector_entry_point', {given[0]}=...), or in sync/async mode "
                        "wrappers=[lambda env: FlattenObservation(FrameStackObservation(env, k))] for a frame stack")


class TriPlanarShearV1Env(ShearEnvBase):
    """
    ## Description

    ``TriPlanarShear-v0``'s task (push the block so that it slides as under hydrostatic loading, the paper's case C)
    on a bench a laboratory could build: the lateral stage is a position servo of finite bandwidth, the thrust
    follows its command through a force loop, commands arrive after a latency, the controller sees what the
    bench measures (noisy rangefinders, load cell, stage encoder), and the specimen can be unknown (``randomize``).
    Physics, reward and episode ends are v0's compiled control step; the bench sits between the agent and it.

    ## Bench dynamics (per control period ``dt``, 5 ms at 200 Hz)

    * **Latency**: a command takes effect ``latency_s`` later, a whole number of control periods (a queue; the
      queue starts full of the starting command: thrust at the load level, tip at ``tip_offset_m``).
    * **Stage servo**: the tip offset follows its command ``u*`` as a first-order lag of bandwidth
      ``stage_bandwidth_hz`` (``tau = 1 / (2 pi f)``). Each period the stage moves at the constant velocity that puts
      the tip at the exact first-order response at the period's end, still limited to ``stage_speed_m_s`` (v0's
      rate limit; the servo's state is the actual position, so a saturated stage does not wind up). Done in the env,
      not the kernel: v0's step already holds the stage velocity constant over a period, so the position at every
      period end is exact and the kernel stays untouched.
    * **Force loop**: the thrust follows its command as a first-order lag of bandwidth ``thrust_bandwidth_hz``; the
      period's constant thrust is the response's mean over the period (the same impulse as the exact response).
    * ``math.inf`` bandwidths and ``latency_s=0`` give the ideal bench: in ``"state"`` mode without
      randomisation v1 then reproduces v0's observations and rewards bitwise (``tests/envs/test_env_v1.py``).

    ## Action Space

    ``Box(-1, 1, (2,), float32)`` as v0: thrust command ``(a0 + 1) / 2 * thrust_scale * load`` and tip offset
    command ``a1 * offset_range_m``; clipped; anything but 2 finite numbers is refused with an error naming it.

    ## Observation Space

    ``observation_mode="state"``: v0's ``Box(34,)`` (exact positions and velocities; for contrast and for the
    ideal study). ``observation_mode="bench"`` (default): ``Box(15,) float32``, what the laboratory measures:

    | Num  | Observation                                                                       | Bound |
    |------|-----------------------------------------------------------------------------------|-------|
    | 0-8  | rangefinders: CP1..CP3 displacement from rest (x1, x2, x3), m, + N(0, ``sensor_noise_m``) each | 0.5 |
    | 9    | load cell: thrust at the period's end, N                                          | 1000  |
    | 10   | stage encoder: tip offset, m                                                      | 0.5   |
    | 11   | load level of the episode, N                                                      | 1000  |
    | 12   | time since the start, s                                                           | 100   |
    | 13-14| previous action                                                                   | 1     |

    No velocities: a controller gets history by keeping it (the scripted controllers of
    :mod:`agents.bench_controllers` difference their own past observations), by a frame stack (``gymnasium.wrappers.FrameStackObservation``; the
    robust PPO ``ppo_robust`` uses 4 frames), or by a recurrent policy (``ppo_recurrent``: sb3-contrib's RecurrentPPO,
    an LSTM; :mod:`agents.train_robust`). The noise is drawn from the env's seeded generator.

    ## Rewards

    ``r_distance + r_action_rate + r_termination``, each defined as in the ideal bench's docstring
    (:class:`envs.triplanar_shear.TriPlanarShearEnv`; the same compiled terms), except that the action-rate term is
    computed on the agent's actions (before the latency and the servos), in this module. The distance is to the
    hydrostatic reference of the episode's (true) specimen at its load level. An episode's return is minus its
    mimicry error in mm (travel-weighted), minus the action-rate cost, minus 50 mm times the untravelled fraction if
    it fails: a return of -1 or more is under the project's 1 mm target (``spec.reward_threshold``).

    ## Starting State

    v0's: the first control period runs in ``reset``. With ``randomize=True`` each reset draws an unknown specimen
    from the env's seeded generator: contact friction angles +-2 deg, tip friction 3-12 deg, mass +-5 % (inertia
    with it), mass centre +-5 mm on each body axis, each plane's dip +-0.5 deg and dip direction +-5 deg (the
    horizontal plane: dip 0-0.5 deg in any direction), load uniform in 27.8-55.6 N; a draw that friction holds at
    rest is drawn again. A ``tip_friction_deg`` given to ``gym.make`` is known hardware and is not drawn.
    ``reset(options={"bench": Bench(...)})`` runs a given bench (the held-out set does); ``start_state(bench)`` gives
    the state it would begin from without beginning it (``get_state``/``set_state`` move a state between envs).
    ``info`` of reset and of every step has the same keys: v0's step keys plus the bench's (``mass_kg``,
    ``mass_centre_m``, ``plane_dips_deg``, ``friction_deg``, ``tip_friction_deg``).

    ## Episode End

    **Termination** (v0's): ``travel`` (success, ``info["is_success"]``), ``lift_off``, ``mass_centre_outside``,
    ``left_plane``, ``arrested``, ``failed`` (``info["reason"]``, :class:`triplanar.outcome.Outcome` labels).
    **Truncation**: ``time_limit`` after ``time_limit_s`` (2 s), by the env itself (the core's step, as v0): 399
    agent steps at 200 Hz (the first period runs in reset). The registered ``max_episode_steps`` is the same 399
    (what tools that read ``spec.max_episode_steps`` see); with a longer ``time_limit_s`` pass
    ``gym.make(..., max_episode_steps=N)`` too, else Gymnasium's ``TimeLimit`` ends the episode at 399 steps.
    A ``step`` after the episode ended warns once (as Gymnasium's CartPole); after a ``reset`` that raised, ``step``
    is refused until a ``reset`` succeeds.

    ## Arguments

    ``gym.make("TriPlanarShearRealistic-v0", **kwargs)`` (or ``"TriPlanarShear-v1"``); each checked where it enters,
    refused with its name (``randomize`` a bool, ``latency_s`` at most ``time_limit_s``, load levels positive; the
    batched env's ``frame_stack``, ``start_bank`` and ``bank_reuse`` are refused by name here):

    | name                 | type          | default   | meaning |
    |----------------------|---------------|-----------|---------|
    | `observation_mode`   | str           | `"bench"` | `"bench"` (what the laboratory measures) or `"state"` (v0's) |
    | `randomize`          | bool          | `False`   | an unknown specimen and load each episode (ranges above) |
    | `stage_bandwidth_hz` | float         | `20.0`    | lateral stage position bandwidth, Hz; `math.inf`: ideal |
    | `thrust_bandwidth_hz`| float         | `30.0`    | force-loop bandwidth, Hz; `math.inf`: ideal |
    | `latency_s`          | float         | `0.005`   | command latency, s, a whole number of control periods |
    | `sensor_noise_m`     | float         | `2e-4`    | rangefinder noise (standard deviation), m |
    | `nominal_specimen`   | path or None  | `None`    | a `fit.json` of `triplanar fit` or a specimen TOML: the nominal specimen (`triplanar.prior.load_prior`; refused naming the field if it is not this bench's) |
    | `render_mode`        | str or None   | `None`    | `"rgb_array"` or `"human"` |
    | any `ShearConfig` field | (see v0)   | (v0's)    | `load_N`, `load_levels`, `load_range`, `control_hz`, `tip_friction_deg`, `stage_speed_m_s`, `offset_range_m`, `thrust_scale`, `travel_m`, `time_limit_s`, reward terms, `specimen`, `foundation` |

    Defaults: a ball-screw linear stage under closed-loop position control and an electromechanical load actuator
    under force control typically reach closed-loop bandwidths of tens of Hz (20 and 30 Hz here); a PC or PLC
    control loop at 200 Hz adds one period of latency; 0.2 mm is a typical laser-triangulation rangefinder's noise
    over a ~10 cm range. These are order-of-magnitude values, not one product's data
    sheet; the design sweep (``docs/actuator-study.md``) varies them.

    ## Rendering

    ``render_fps`` is the control rate: one frame per control period, so a recorded video
    (``gymnasium.wrappers.RecordVideo``) lasts as long as the episode. A frame is drawn with Pillow (overhead view,
    a few ms). ``render_mode="human"`` without a display warns once and draws nothing.

    ## Version History

    * v1: bench dynamics (stage servo, force loop, latency), bench observations, unknown specimens, ``env.dt``,
      ``render_fps`` = control rate, the same ``info`` keys at reset and step, a fast Pillow renderer. Since the
      shared env core: one truncation, ``time_limit_s`` (the registered ``max_episode_steps=399``, which disagreed
      with it as soon as ``time_limit_s`` changed, is gone; at the defaults the episodes are bitwise the same);
      a batched version (``gym.make_vec``, :mod:`envs.vector_v1`).
    * v0: the ideal, known bench (:class:`envs.triplanar_shear.TriPlanarShearEnv`), unchanged.
    * ``TriPlanarShearRealistic-v0``: this env under a name of its own (the realistic bench is a task, not a newer
      version of the ideal one); ``TriPlanarShear-v1`` makes the same class. Since then: ``max_episode_steps=399``
      and ``reward_threshold=-1`` registered, ``info["reason_code"]`` (as the batched env's), a warning on ``step``
      after the end, ``step`` refused after a failed ``reset``, arguments checked by name. Rollouts of valid use are
      bitwise the same (``benchmarks/fingerprint.py --compare``).
    """

    def __init__(self, render_mode: str | None = None, *, observation_mode: str = DEFAULT_BENCH.observation_mode,
                 randomize: bool = DEFAULT_BENCH.randomize, stage_bandwidth_hz: float = DEFAULT_BENCH.stage_bandwidth_hz,
                 thrust_bandwidth_hz: float = DEFAULT_BENCH.thrust_bandwidth_hz,
                 latency_s: float = DEFAULT_BENCH.latency_s, sensor_noise_m: float = DEFAULT_BENCH.sensor_noise_m,
                 nominal_specimen: str | os.PathLike | None = None, **kwargs: Any):
        refuse_batch_arguments(kwargs)
        if nominal_specimen is not None:  # identify, then control: the fitted specimen becomes the nominal one
            from triplanar.prior import load_prior  # (only when asked for)
            kwargs["specimen"] = load_prior(nominal_specimen, *make_config(None, **kwargs).base_specimen())
        self.config: ShearConfig = make_config(None, **kwargs)
        self.bench = BenchConfig(stage_bandwidth_hz, thrust_bandwidth_hz, latency_s, sensor_noise_m,
                                 observation_mode, randomize)
        self.bench.validate(self.config.dt, self.config.time_limit_s)
        self._init_core(render_mode)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_space = observation_space_of(observation_mode)
        self._bc = bench_constants(self.bench, self.config)
        self._bs = np.zeros(N_BS)
        self._queue = np.zeros((self.bench.latency_periods(self.config.dt), 2))
        self._no_noise = np.zeros(0)
        self._applied = np.zeros(2)
        self._episode: Bench | None = None
        self._start_cache = StartCache()   # this env's starts (a bench it has run before starts from here)

    # -- Gymnasium API ---------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self._begin_reset()
        super().reset(seed=seed)
        bench = bench_option(options)
        if bench is None:
            bench, start = draw_start(self.np_random, self.config, self.bench.randomize, self._specimen,
                                      self._foundation, self._start_cache)
        else:
            start = bench_start(self.config, bench, self._start_cache)
        self._episode = bench
        self._episode_info = bench.info()
        reset_bench_state(self.config, start, self._bs, self._queue)
        self._load_start(start)
        return self._observation(), self._info(0)

    def step(self, action):
        self._check_step_allowed()
        raw = check_action(action)
        if raw.dtype != np.float32 and raw.dtype != np.float64:  # (ints, float16: as exact in float64)
            raw = raw.astype(np.float64)
        d0, d1 = bench_command(raw, self._bc, self._bs, self._queue, self._y, self._st, self._applied)
        code = self._control_step(self._applied)
        r_rate = action_rate_reward(self.config.action_rate_coef, d0, d1)
        reward = float(self._inf[IN_R_DIST] + self._inf[IN_R_TERM]) + r_rate
        info = self._info(code)
        info["reward_action_rate"] = r_rate
        return self._observation(), reward, code > 0, bool(self._inf[IN_TRUNC]), info

    # -- helpers ---------------------------------------------------------------------------------
    def _observation(self) -> np.ndarray:
        if self.bench.observation_mode == "state":
            return state_observation(self._obs, self._bs).astype(np.float32)
        noise = self.np_random.normal(0.0, self.bench.sensor_noise_m, 9) if self.bench.sensor_noise_m > 0 \
            else self._no_noise
        return bench_observation(self._obs, noise, self._bs, self._y, self._st, BENCH_HIGH)

    def _info(self, code: int) -> dict[str, Any]:
        info = info_dict(self._inf, code)
        info.update(self._episode_info)
        info["thrust_N"] = float(self._inf[IN_THRUST])
        info["load_cell_N"] = float(self._bs[BS_THRUST])
        return info

    def get_state(self) -> BenchState:
        """The episode's state now, the bench's included (copies; after ``reset``): the truth the ``limit``
        controller plans from."""
        return BenchState(**vars(super().get_state()), bc=self._bc.copy(), bs=self._bs.copy(),
                          queue=self._queue.copy())

    def start_state(self, bench: Bench, *, reference: bool = True) -> tuple[BenchState, np.ndarray]:
        """The state ``reset(options={"bench": bench})`` would begin from and its state observation (float64, as
        ``observation_mode="state"`` observes it before float32), without beginning an episode (this env is left as
        it was; StartError if the block cannot start). ``reference`` False: without the case-C reference run
        (:func:`envs.core.episode_start`: the motion and outcomes are the episode's, not its rewards nor
        ``OBS_REF``; what a fit to measured positions needs, :mod:`agents.estimator`)."""
        if not isinstance(bench, Bench):
            raise TypeError(f"start_state: bench must be an envs.triplanar_shear_v1.Bench, got {bench!r}")
        start = bench_start(self.config, bench, self._start_cache if reference else None, reference=reference)
        bs, queue = np.zeros_like(self._bs), np.zeros_like(self._queue)
        reset_bench_state(self.config, start, bs, queue)
        obs = state_observation(start.obs, bs)
        return BenchState(start.y.copy(), start.p.copy(), start.modes.copy(), start.armed.copy(), start.st.copy(),
                          np.array(start.reference), self._cfg.copy(), bc=self._bc.copy(), bs=bs, queue=queue), obs

    def set_state(self, state: BenchState) -> None:
        """Continue the episode from ``state`` (:meth:`envs.base.ShearEnvBase.set_state`, the bench's state too)."""
        if not isinstance(state, BenchState):
            raise TypeError(f"set_state: expected a BenchState (TriPlanarShearV1Env.get_state), got {state!r}")
        if not np.array_equal(state.bc, self._bc) or np.shape(state.queue) != self._queue.shape:
            raise ValueError("set_state: state.bc or state.queue is of another bench (servos, latency)")
        super().set_state(state)
        self._bs[:] = state.bs
        self._queue[:] = state.queue

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        state["_start_cache"] = StartCache()   # (a copy of the env starts with its own, empty)
        return state

    @property
    def episode_bench(self) -> Bench:
        """This episode's specimen, foundation and load (the truth a controller does not see)."""
        if self._episode is None:
            raise gym.error.ResetNeeded("call reset() first")
        return self._episode


BENCH_FIELDS = tuple(f.name for f in fields(BenchConfig))
