"""The information-limited bound: how close to case C a controller that sees only the bench can get, per bench.

``limit`` (:mod:`agents.limit`) knows the specimen; a bench controller must learn it from the rangefinders while it
acts. Per bench the bound is ``hypot(e, d)`` (mm): ``e`` the mimicry error of ``limit`` playing ``mpc``'s designed
excitation first (:meth:`agents.mpc.MPCController.start_command`, its first 8 periods: what a bench controller
plays to learn the tip), ``d`` the *deviation bound* along those commands: what the measurements before each period
leave unknown of the block's deviation from its case-C path, travel-averaged. Adding the two in quadrature is the
error of a controller whose actuator-driven and information-driven deviations are independent
(``docs/actuator-study.md``, "The information-limited bound"; on the tuning benches ``mpc``'s excess over ``limit``
equalled ``d``).

The deviation bound (a linearised Cramér-Rao form, about the bench's truth): along the commands the noiseless
rangefinder signals (nine contact-point displacements per period) are differentiated by central differences
(:data:`STEP` of each range; one-sided at its edge) with respect to every unknown the bench draws (tip and contact
friction, mass centre, mass, dips, the tilted planes' dip directions; not the horizontal plane's direction, an angle
around the circle, nor a tip the design knows). The Fisher information of the first ``k`` periods under the
rangefinders' Gaussian noise (the bench's ``sensor_noise_m``), added to a Gaussian prior of the ranges' variances
(a uniform range's), gives the unknowns' covariance before each period; propagated through the sensitivities of the
block's deviation from the case-C reference at its travel (the reference table differentiated at a fixed travel,
interpolated as the env does), it gives the expected horizontal distance of each contact point (mean over the
three: the env's distance). What it is not: a proof that no controller does better (another excitation gives
another bound; stick/slip makes the signals only piecewise smooth; the prior is Gaussian for uniform).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from envs.core import OBS_POS, StartError, make_config
from envs.prediction import snapshot
from envs.triplanar_shear_v1 import Bench, BenchConfig, TriPlanarShearV1Env

from .controller_base import Controller
from .estimator import PARAMETERS, bench_of, geometry_ranges, hypothesis_of, prior_ranges
from .limit import LimitController
from .mpc import MPCController

STEP = 0.02       # central-difference step, a fraction of each unknown's range
SAMPLES = 4000    # normal draws for the expected distance of a 2-d Gaussian
MIN_COVERED = 0.5  # a truncated bound (a perturbed bench ended early) must cover at least this share of the periods


def signals(bench: Bench, commands: np.ndarray, env_kwargs: dict[str, Any] | None = None
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """The noiseless rangefinder signals (periods x 9, m) of ``bench`` under ``commands`` on the bench of
    ``env_kwargs`` (its stage and latency), its case-C reference table and the travel target."""
    env = TriPlanarShearV1Env(**{**(env_kwargs or {}), "observation_mode": "state", "sensor_noise_m": 0.0})
    env.reset(seed=0, options={"bench": bench})
    reference = np.array(snapshot(env).ref)
    out = []
    for raw in commands:
        obs, _, terminated, truncated, _ = env.step(np.asarray(raw, dtype=np.float32))
        out.append(np.array(obs[OBS_POS:OBS_POS + 9], dtype=float))
        if terminated or truncated:
            break
    return np.array(out), reference, env.config.travel_m


def at_travel(reference: np.ndarray, s: np.ndarray, travel: float) -> np.ndarray:
    """The reference table (rows at equal steps of travel up to ``travel``) at each travel of ``s``, linear between
    rows and held at the ends, as the env reads it."""
    grid = np.linspace(0.0, travel, len(reference))
    return np.stack([np.interp(s, grid, column) for column in reference.T], axis=1)


def expected_distance_mm(cov: np.ndarray, z: np.ndarray) -> float:
    """The mean over the three contact points of the expected horizontal distance (mm) of a zero-mean Gaussian
    displacement with covariance ``cov`` (9 x 9: x1, x2, x3 of CP1..CP3)."""
    total = 0.0
    for i in range(3):
        block = cov[np.ix_([3 * i, 3 * i + 2], [3 * i, 3 * i + 2])]
        factor = np.linalg.cholesky(block + 1e-24 * np.eye(2))
        total += float(np.mean(np.linalg.norm(z @ factor.T, axis=1)))
    return 1e3 * total / 3.0


def travel_average(distance: np.ndarray, travel: np.ndarray) -> float:
    """The env's trapezoid rule over the travel of each period."""
    ds = np.abs(np.diff(np.concatenate([[0.0], travel])))
    previous = np.concatenate([[distance[0]], distance[:-1]])
    return float(np.sum(0.5 * (distance + previous) * ds) / np.sum(ds))


def unknown_ranges(known_tip_deg: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(low, high, free)`` of the hypothesis vector (:func:`agents.estimator.hypothesis_of`): v1's ranges about
    its nominal specimen; ``free`` the indices differentiated (a range of some width, not an angle around the
    circle, not a tip the design knows)."""
    prior, foundation = make_config(None).base_specimen()
    low, high = prior_ranges(prior)
    glow, ghigh, circular = geometry_ranges(prior, foundation)
    low, high = np.concatenate([low, glow]), np.concatenate([high, ghigh])
    if known_tip_deg is not None:
        low[0] = high[0] = float(known_tip_deg)
    free = np.flatnonzero((high > low) & ~np.concatenate([np.zeros(len(PARAMETERS), dtype=bool), circular]))
    return low, high, free


def _sensitivities(bench: Bench, commands: np.ndarray, env_kwargs: dict[str, Any] | None, known_tip_deg,
                   truncate: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float] | None:
    """``(d_signal, d_reference, travel of each period, span of the free unknowns, travel target)``: the first two
    (unknowns, periods, 9), over the periods every perturbed bench ran (``truncate``; else None if one ended
    early)."""
    prior, _ = make_config(None).base_specimen()
    low, high, free = unknown_ranges(known_tip_deg)
    theta = hypothesis_of(bench)
    centre = signals(bench_of(prior, theta, bench.load_N), commands, env_kwargs)
    path, _, travel = centre
    pairs, steps = [], []
    for j in free:
        ends = np.clip(theta[j] + np.array([STEP, -STEP]) * (high[j] - low[j]), low[j], high[j])
        runs = []
        for k, end in enumerate(ends):
            try:
                runs.append(signals(bench_of(prior, np.where(np.arange(len(theta)) == j, end, theta), bench.load_N),
                                    commands[:len(path)], env_kwargs))
            except StartError:   # the perturbed block cannot even start there: one-sided from the centre
                runs.append(centre)
                ends[k] = theta[j]
        pairs.append(runs)
        steps.append(ends[0] - ends[1])
    if not all(steps):
        return None
    n = min([len(path)] + [len(run[0]) for pair in pairs for run in pair])
    if n < len(path) and (not truncate or n < MIN_COVERED * len(path)):
        return None
    s = path[:n, 0]
    d_signal = np.array([(up[:n] - down[:n]) / h for ((up, _, _), (down, _, _)), h in zip(pairs, steps)])
    d_reference = np.array([(at_travel(ru, s, travel) - at_travel(rd, s, travel)) / h
                            for ((_, ru, _), (_, rd, _)), h in zip(pairs, steps)])
    return d_signal, d_reference, s, (high - low)[free], travel


def deviation_bound(bench: Bench, commands: np.ndarray, env_kwargs: dict[str, Any] | None = None,
                    known_tip_deg: float | None = None, truncate: bool = False) -> dict[str, Any] | None:
    """The reference and deviation bounds (module docstring) of ``bench`` under ``commands`` on the bench of
    ``env_kwargs``: travel averages (mm), their profiles per period and the travel fraction of each period. None if a
    perturbed bench ends before the bench does (the differences are then not defined), unless ``truncate``: then
    over the periods all ran (at least :data:`MIN_COVERED` of them; ``covered``: the share)."""
    found = _sensitivities(bench, commands, env_kwargs, known_tip_deg, truncate)
    if found is None:
        return None
    d_signal, d_reference, s, span, travel = found
    noise = float((env_kwargs or {}).get("sensor_noise_m", BenchConfig().sensor_noise_m))
    information = np.diag(12.0 / span ** 2)  # the prior: a uniform range's variance
    z = np.random.default_rng(0).standard_normal((SAMPLES, 2))
    n = len(s)
    reference_mm, deviation_mm = np.zeros(n), np.zeros(n)
    for k in range(n):
        cov = np.linalg.inv(information)  # given the periods before k
        g_reference = d_reference[:, k, :].T
        g_deviation = (d_signal[:, k, :] - d_reference[:, k, :]).T
        reference_mm[k] = expected_distance_mm(g_reference @ cov @ g_reference.T, z)
        deviation_mm[k] = expected_distance_mm(g_deviation @ cov @ g_deviation.T, z)
        jacobian = d_signal[:, k, :].T / noise
        information = information + jacobian.T @ jacobian
    return {"reference_bound_mm": travel_average(reference_mm, s),
            "deviation_bound_mm": travel_average(deviation_mm, s), "reference_profile_mm": reference_mm.tolist(),
            "deviation_profile_mm": deviation_mm.tolist(), "travel_fraction": (s / travel).tolist(),
            "covered": n / len(commands)}


@dataclass
class InformationBound(Controller):
    """The bound's episode (module docstring): ``mpc``'s start for ``start_periods`` decisions, then ``limit``; the
    commands kept for :meth:`outcome`. Not a controller a laboratory can build (it reads the env's true state)."""

    name: str = "information_bound"
    start_periods: int = MPCController.start_periods
    needs_env: bool = True
    commands: list = field(default_factory=list)
    _limit: LimitController = field(default_factory=LimitController)
    _start: MPCController = field(default_factory=MPCController)
    _config: Any = None

    def bind(self, env: Any) -> None:
        self._limit.bind(env)

    def reset(self, load_N: float, config: Any) -> None:
        self._limit.reset(load_N, config)
        self._config, self.commands = config, []

    def act(self, obs: np.ndarray) -> np.ndarray:
        period = len(self.commands) + 1
        if period <= self.start_periods:
            action = np.asarray(self._start.start_command(period, self._config), dtype=np.float32)
        else:
            action = self._limit.act(obs)
        self.commands.append(np.array(action, dtype=float))
        return action

    def outcome(self, played: Any, bench: Bench, env_kwargs: dict[str, Any] | None = None,
                known_tip_deg: float | None = None) -> Any:
        """``played`` (the episode's :class:`agents.heldout.Outcome`) with its error replaced by the bound,
        ``hypot(e, d)``; a failed episode stays failed (``limit`` with the start lost the block); ``reason`` says
        ``information_bound`` and how much of the travel the deviation bound covers (where it is not defined on
        :data:`MIN_COVERED` of the periods, ``e`` alone: a bound on the low side)."""
        if not played.success:
            return played
        found = deviation_bound(bench, np.array(self.commands), env_kwargs, known_tip_deg, truncate=True)
        if found is None:   # a perturbed bench ended in the first MIN_COVERED of the periods: limit's error alone
            return replace(played, reason="information_bound (deviation not defined: limit's error alone)")
        bound = math.hypot(played.mimicry_error_mm, found["deviation_bound_mm"])
        return replace(played, mimicry_error_mm=bound,
                       reason=f"information_bound (deviation {found['deviation_bound_mm']:.3f} mm over "
                              f"{100 * found['covered']:.0f} % of the periods)")
