"""Estimating the unknown specimen and the block's state from the bench's observations: a bank of hypotheses
(a particle filter over the specimen, with resample-move).

**Why this estimator.** Given the specimen, the block's motion is deterministic: the bench's only randomness is
the rangefinder noise (Gaussian, ``sensor_noise_m``), and the controller knows every command it sent. So each
hypothesis (a specimen drawn from the prior: v1's unknowns, ``docs/environment.md``: tip friction, the three
contact friction angles, the mass centre and, with ``vary_geometry``, the mass and the three planes' tilts) is
simulated forward with the env's own compiled step (:func:`envs.prediction.step_state`) from its own start, and its
weight is the exact likelihood of the measured contact-point displacements under it. This handles what a UKF or an
EKF would linearise badly (stick/slip switches and events make the state map non-smooth) and needs no process
noise model; moving-horizon estimation would need the same rollouts per iteration of an optimiser, which does not
fit a 5 ms period. Each hypothesis carries the block's full state and its own case-C reference, so the planner
(:mod:`agents.mpc`) predicts from the likely hypotheses directly. A hypothesis that friction would hold at rest is
not drawn (the bench's block started: the bank is filled with hypotheses that start). ``model_error_m`` is added to
the sensor noise for what no finite bank matches exactly.

**Resample-move.** A finite bank collapses: within a few periods one hypothesis carries all the weight, and it is
rarely the bench's specimen (with 32 hypotheses in 14 unknowns, a fixed bank ended the tuning benches' episodes with
a tip-friction error of 3.1 deg RMS, worse than the prior's spread). So whenever the effective sample size falls
below ``rejuvenate_ess`` times the bank's size, the bank is resampled by weight and each hypothesis takes
``move_steps`` Metropolis-Hastings steps whose target is the posterior given every measurement so far
(:meth:`SpecimenBank._resample_move`, Gilks & Berzuini 2001): a perturbed copy is run from its own start with every
command sent so far, weighed by every measurement so far and accepted against its parent with that likelihood ratio
(the prior is uniform within its ranges among the specimens that start). The bank so stays a sample of the
posterior, and its interval is one (``tests/agents/test_estimator_posterior.py``). ``move="greedy"`` keeps the
earlier move (the least likely half replaced by perturbed copies kept when they fit better, the proposal density
not divided out: it concentrates the bank faster than the posterior; ``docs/notes/mpc-tuning-rounds.md`` compares them).

**Refinement** (``refine_every``; zero: none, the default here; ``mpc`` refines every 10 periods). Every
``refine_every`` periods the bank is replaced by an importance sample from a Laplace proposal around a least-squares
fit of the unknowns to every measurement so far (:meth:`SpecimenBank.refine`, :mod:`agents.refine`), which reaches
the noise level where the random walk is slow. It sharpens the bank as a bank four times larger does, at half its
CPU; the tip friction comes out closer, the contact friction and the mass centre hardly (the measurements do not
determine them one by one; ``docs/notes/mpc-tuning-rounds.md``, sixth round). Nor can any estimator of the same data, to first
order: a linearised information bound (``benchmarks/information_bound.py``, ninth round) leaves 0.18 mm of the block's
deviation from its case-C path unknown on the tuning benches, about what ``mpc`` loses to ``limit``.

**Bounded cost** (``move_periods``; zero: unbounded, the bank's default; ``mpc`` sets 30). A move and a refinement
replay every period so far, so their cost grows with the episode's length. With ``move_periods`` > 0 the bank
resample-moves and refines only in its first ``move_periods`` periods; after them it only weighs its hypotheses by
each new measurement (a plain particle filter), and no update costs more than one at ``move_periods``.

**Divergence.** If every hypothesis is ruled out (each ended the test while the bench runs on, or its state is not
finite), or the weighted covariance is not finite and positive definite, the weights go back to the prior
(uniform) and :attr:`SpecimenBank.fallbacks` counts it; the controller reports it in its ``info``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from envs.core import N_INFO, OBS_DIM, OBS_POS, StartError, new_workspace, reference_deviation
from envs.prediction import BenchState, step_state
from envs.triplanar_shear_v1 import (
    B_RANGE,
    DEFAULT_BENCH,
    TRAINING_RANGES,
    Bench,
    BenchRanges,
    TriPlanarShearV1Env,
    draw_bench,
    unknown_bench,
)
from triplanar import kernel as K
from triplanar.outcome import RUNNING
from triplanar.specimen import Foundation, Plane, Specimen

from .refine import laplace_fit

PARAMETERS = ("tip_friction_deg", "friction1_deg", "friction2_deg", "friction3_deg", "mass_centre1_m",
              "mass_centre2_m", "mass_centre3_m")
GEOMETRY = ("mass_kg", "dip1_deg", "dip2_deg", "dip3_deg")  # varied with ``vary_geometry``, and reported
DIRECTIONS = ("dip_direction1_deg", "dip_direction2_deg", "dip_direction3_deg")  # varied, not reported
N_REPORTED = len(PARAMETERS) + len(GEOMETRY)
FAILED_RESIDUAL = 30.0  # a hypothesis's residual, in noise units, from where it no longer explains the bench
MOVES = ("mh", "greedy")  # resample-move: a Metropolis-Hastings move, or the earlier greedy replacement


def reference_distance_mm(a: np.ndarray, b: np.ndarray) -> float:
    """The distance between two case-C reference tables of the same travel, as the env measures the mimicry error:
    the horizontal distance of each contact point, averaged over the three and over the travel (mm)."""
    d = (np.asarray(a) - np.asarray(b)).reshape(len(a), 3, 3)
    return 1e3 * float(np.mean(np.hypot(d[:, :, 0], d[:, :, 2])))


def latin_hypercube(rng: np.random.Generator, n: int, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``n`` points, one in each of ``n`` equal strata of every coordinate (the bank covers each range evenly)."""
    d = len(low)
    u = (np.argsort(rng.random((n, d)), axis=0) + rng.random((n, d))) / n
    return low + u * (high - low)


def parameters_of(specimen: Specimen) -> np.ndarray:
    return np.concatenate([[specimen.tip_friction_deg], np.asarray(specimen.friction_deg, dtype=float),
                           np.asarray(specimen.mass_centre_m, dtype=float)])


def hypothesis_of(bench: Bench) -> np.ndarray:
    """A bench's unknowns as one hypothesis vector: :data:`PARAMETERS`, :data:`GEOMETRY`, :data:`DIRECTIONS`."""
    planes = bench.foundation.planes
    return np.concatenate([parameters_of(bench.specimen), [bench.specimen.mass_kg],
                           [plane.dip_deg for plane in planes], [plane.dip_direction_deg for plane in planes]])


def bench_of(prior: Specimen, theta: np.ndarray, load_N: float) -> Bench:
    """The bench of a whole hypothesis vector (:func:`hypothesis_of`'s inverse): ``prior`` with ``theta``'s
    unknowns, on planes of its dips and dip directions, at ``load_N``."""
    n = len(PARAMETERS)
    planes = tuple(Plane(float(d), float(a)) for d, a in zip(theta[n + 1:n + 4], theta[n + 4:n + 7]))
    return unknown_bench(prior, tuple(float(v) for v in theta[1:4]), float(theta[0]), float(theta[n]) / prior.mass_kg,
                         np.array(theta[4:7], dtype=float), planes, float(load_N), prior.name)


def with_parameters(specimen: Specimen, theta: np.ndarray) -> Specimen:
    return replace(specimen, tip_friction_deg=float(theta[0]), friction_deg=tuple(float(v) for v in theta[1:4]),
                   mass_centre_m=np.array(theta[4:7], dtype=float))


def prior_ranges(prior: Specimen, intervals: dict[str, tuple[float, float]] | None = None,
                 ranges: BenchRanges = TRAINING_RANGES) -> tuple[np.ndarray, np.ndarray]:
    """The unknown specimen's ``ranges`` (v1's, ``docs/environment.md``) around ``prior``'s contact friction and mass
    centre, the tip friction over its whole range; a parameter with an identified interval (``intervals``, e.g.
    :func:`triplanar.prior.fitted_intervals` of a fit) is drawn within that interval instead."""
    centre = parameters_of(prior)
    half = np.array([0.0] + [ranges.friction_deg] * 3 + [ranges.mass_centre_m] * 3)
    low, high = centre - half, centre + half
    low[0], high[0] = ranges.tip_friction_deg
    for name, (lo, hi) in (intervals or {}).items():
        k = PARAMETERS.index(name)
        low[k], high[k] = lo, hi
    return low, high


def geometry_ranges(prior: Specimen, foundation: Foundation, ranges: BenchRanges = TRAINING_RANGES
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``ranges`` (v1's) of the mass, the dips and the dip directions (:func:`envs.triplanar_shear_v1.draw_bench`),
    and which coordinates are angles around the circle (a horizontal plane's dip direction: any)."""
    tilt, direction = ranges.tilt_deg, ranges.tilt_direction_deg
    low, high, circular = [prior.mass_kg * (1 - ranges.mass)], [prior.mass_kg * (1 + ranges.mass)], [False]
    flat = [plane.dip_deg < tilt for plane in foundation.planes]
    for plane, level in zip(foundation.planes, flat):
        low.append(0.0 if level else plane.dip_deg - tilt)
        high.append(tilt if level else plane.dip_deg + tilt)
        circular.append(False)
    for plane, level in zip(foundation.planes, flat):
        low.append(0.0 if level else plane.dip_direction_deg - direction)
        high.append(360.0 if level else plane.dip_direction_deg + direction)
        circular.append(level)
    return np.array(low), np.array(high), np.array(circular)


@dataclass
class SpecimenBank:
    """The bank of hypotheses (module docstring) for one episode."""

    prior: Specimen
    foundation: Foundation
    env_kwargs: dict
    size: int = 32
    seed: int = 0
    sensor_noise_m: float = DEFAULT_BENCH.sensor_noise_m
    model_error_m: float = 6e-4
    intervals: dict | None = None
    vary_geometry: bool = True
    max_rounds: int = 8
    rejuvenate_ess: float = 0.5
    jitter: float = 0.5
    move: str = "mh"
    move_steps: int = 3
    refine_every: int = 0
    refine_evaluations: int = 30
    refine_inflation: float = 1.5
    move_periods: int = 0
    ranges: BenchRanges = TRAINING_RANGES   # what the bench's unknown specimen is drawn from (the prior's support)

    def reset(self, load_N: float) -> None:
        if self.move not in MOVES:
            raise ValueError(f"move must be one of {MOVES}, got {self.move!r}")
        if int(self.move_steps) < 1:
            raise ValueError(f"move_steps must be a positive integer, got {self.move_steps!r}")
        self._env = TriPlanarShearV1Env(**self.env_kwargs)
        self.load_N = float(load_N)
        low, high = prior_ranges(self.prior, self.intervals, self.ranges)
        glow, ghigh, gcircular = geometry_ranges(self.prior, self.foundation, self.ranges)
        self.low, self.high = np.concatenate([low, glow]), np.concatenate([high, ghigh])
        self.circular = np.concatenate([np.zeros(len(low), dtype=bool), gcircular])
        self.resolution = (self.high - self.low)[:N_REPORTED] / self.size
        self._rng = np.random.default_rng([self.seed, round(load_N * 1000)])
        self._applied, self._obs, self._inf = np.zeros(2), np.zeros(OBS_DIM), np.zeros(N_INFO)
        self._ws = new_workspace()
        self._stepped = self._starts = self._bare_starts = 0   # the work done (work_counts)
        self.theta, self.states, observations = [], [], []
        for _ in range(self.max_rounds):  # until the bank is full of hypotheses that start, as the bench's did
            for theta in latin_hypercube(self._rng, self.size, low, high):
                state, full = self._start(self._hypothesis(theta))
                if state is not None:
                    self.theta.append(full)
                    self.states.append(state)
                    observations.append(self._obs.copy())
                if len(self.states) == self.size:
                    break
            if len(self.states) == self.size:
                break
        if not self.states:
            raise StartError(f"no hypothesis of the prior starts at {load_N:g} N")
        self.theta = np.array(self.theta)
        self.observations = np.array(observations)  # each hypothesis's own state observation now (its deviation)
        self.log_w = np.zeros(len(self.states))  # log weight: the likelihood since the last resampling
        self.ll = np.zeros(len(self.states))  # the whole history's log-likelihood (the move's target)
        self.alive = np.ones(len(self.states), dtype=bool)
        self.fallbacks = self.rejuvenations = self.proposed = self.accepted = self.refinements = self.refined = 0
        self.last_fit_cost = math.nan  # the last refinement's least-squares cost (its negative log-likelihood)
        self.diverged = False
        self._history: list[tuple[np.ndarray, np.ndarray]] = []
        self._counted_from = 0  # measurements before a fallback no longer count
        self._predicted: np.ndarray | None = None   # the command predict() advanced the bank by, not yet weighed

    def _hypothesis(self, theta: np.ndarray) -> Bench:
        """The prior with ``theta``'s friction and mass centre; with ``vary_geometry`` also a mass and plane tilts,
        drawn as v1 draws them (:func:`envs.triplanar_shear_v1.draw_bench`), which the bench's unknown specimen
        has too."""
        specimen, foundation = with_parameters(self.prior, theta), self.foundation
        if self.vary_geometry:
            drawn = draw_bench(self._rng, specimen, foundation, self.ranges)
            return replace(drawn, specimen=replace(drawn.specimen, friction_deg=specimen.friction_deg,
                                                   tip_friction_deg=specimen.tip_friction_deg,
                                                   mass_centre_m=specimen.mass_centre_m, name=self.prior.name),
                           load_N=self.load_N)
        return Bench(specimen, foundation, self.load_N)

    def _bench_of(self, theta: np.ndarray) -> Bench:
        """The bench of a hypothesis vector (:func:`hypothesis_of`'s inverse)."""
        if not self.vary_geometry:
            return Bench(with_parameters(self.prior, theta), self.foundation, self.load_N)
        return bench_of(self.prior, theta, self.load_N)

    def _start(self, bench: Bench, reference: bool = True) -> tuple[BenchState | None, np.ndarray]:
        """The hypothesis's start (None if friction holds it at rest: the bench's block did start); its state
        observation is left in ``_obs``, as :meth:`_advance` leaves each period's. ``reference`` False: without its
        case-C reference (:meth:`TriPlanarShearV1Env.start_state`: its positions and outcomes, not its deviation;
        ``_obs`` in float64)."""
        if not reference:
            self._bare_starts += 1
            try:
                state, self._obs[:] = self._env.start_state(bench, reference=False)
            except StartError:
                return None, hypothesis_of(bench)
            return state, hypothesis_of(bench)
        self._starts += 1
        try:
            obs, _ = self._env.reset(seed=0, options={"bench": bench})
        except StartError:
            return None, hypothesis_of(bench)
        self._obs[:] = obs
        return self._env.get_state(), hypothesis_of(bench)

    def start_hypothesis(self, theta: np.ndarray, reference: bool = True) -> tuple[BenchState | None, np.ndarray]:
        """The start of the hypothesis vector ``theta`` (:func:`hypothesis_of`'s layout) on this episode's bench and
        load, and its state observation (None and the last one if friction holds it at rest); ``reference`` False:
        without its case-C reference (:meth:`_start`: for residuals of positions, not a deviation)."""
        state, _ = self._start(self._bench_of(theta), reference)
        return state, self._obs.copy()

    def step_hypothesis(self, state: BenchState, raw: np.ndarray) -> tuple[bool, np.ndarray]:
        """One period of a hypothesis's ``state`` (run in place) under command ``raw``: whether it ended the test,
        and its state observation."""
        ended = self._step(state, raw)
        return ended, self._obs.copy()

    def work_counts(self) -> tuple[int, float, int, int]:
        """The work done since :meth:`reset` began: hypothesis periods stepped, the kernel's right-hand-side
        evaluations in them, fresh starts with and without the case-C reference (what
        :class:`agents.estimate_worker.WorkPrices` prices)."""
        return self._stepped, float(self._ws[K.W_COUNT, K.C_NFEV]), self._starts, self._bare_starts

    @property
    def travel_m(self) -> float:
        """The bench's travel (the case-C reference's span)."""
        return float(self._env.config.travel_m)

    def _advance(self, s: BenchState, raw: np.ndarray, measured: np.ndarray) -> float:
        """One period of hypothesis ``s``; the log-likelihood of ``measured`` (-inf if it ended the test)."""
        return self._log_likelihood(self._step(s, raw), self._obs, measured)

    def _step(self, s: BenchState, raw: np.ndarray) -> bool:
        """One period of hypothesis ``s`` under command ``raw`` (its state observation left in ``_obs``): whether it
        ended the test (or its state is not finite)."""
        self._stepped += 1
        code = step_state(s.y, s.p, s.modes, s.armed, s.st, s.ref, s.cfg, s.bc, s.bs, s.queue, raw,
                          self._applied, self._obs, self._inf, self._ws)
        return code != RUNNING or not np.all(np.isfinite(s.y))

    def _log_likelihood(self, ended: bool, obs: np.ndarray, measured: np.ndarray) -> float:
        """The log-likelihood of ``measured`` for a hypothesis whose state observation is ``obs`` (-inf if it
        ``ended`` the test); its residual is left in ``_residual``."""
        self._residual = r = obs[OBS_POS:OBS_POS + 9] - measured
        ll = -0.5 * float(r @ r) / (self.sensor_noise_m ** 2 + self.model_error_m ** 2)
        return -math.inf if ended or not math.isfinite(ll) else ll

    def _replay(self, s: BenchState) -> float:
        """Run a new hypothesis from its start with every command sent so far: its whole history's
        log-likelihood (-inf if it ended the test or does not explain a measurement)."""
        ll = 0.0
        for k, (raw, measured) in enumerate(self._history):
            inc = self._advance(s, raw, measured)
            if not math.isfinite(inc):
                return -math.inf
            if k >= self._counted_from:
                ll += inc
        return ll

    def _residuals(self, theta: np.ndarray) -> np.ndarray:
        """Hypothesis ``theta``'s residuals against every counted measurement so far, in units of the likelihood's
        noise, so that half their sum of squares is the negative log-likelihood; from where it does not start, ends
        the test or goes non-finite, :data:`FAILED_RESIDUAL`."""
        sigma = self.noise_m
        out = np.full(9 * (len(self._history) - self._counted_from), FAILED_RESIDUAL)
        state, _ = self._start(self._bench_of(theta), reference=False)
        if state is None:
            return out
        for k, (raw, measured) in enumerate(self._history):
            if not math.isfinite(self._advance(state, raw, measured)):
                break
            j = k - self._counted_from
            if j >= 0:
                out[9 * j:9 * j + 9] = self._residual / sigma
        return out

    @property
    def noise_m(self) -> float:
        """The likelihood's noise (m): the rangefinders' and the model's error in quadrature."""
        return math.sqrt(self.sensor_noise_m ** 2 + self.model_error_m ** 2)

    def likeliest(self) -> int | None:
        """The index of the likeliest live hypothesis (None if none is alive)."""
        alive = np.flatnonzero(self.alive)
        return int(alive[np.argmax(self.ll[alive])]) if len(alive) else None

    def free_unknowns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What a fit moves: the mask of the unknowns with a range (not the horizontal planes' dip directions, and
        none of the geometry without ``vary_geometry``), and their box's low ends and spans."""
        free = (self.high > self.low) & ~self.circular
        if not self.vary_geometry:
            free[len(PARAMETERS):] = False
        return free, self.low[free], (self.high - self.low)[free]

    def refine(self) -> bool:
        """Replace the bank by an importance sample of the posterior from a Laplace proposal (:mod:`agents.refine`):
        the unknowns fitted by least squares to every measurement so far from the likeliest hypothesis, the
        horizontal planes' dip directions held at its values. Each draw that starts is weighed by its likelihood
        over the proposal's density. Returns False (the bank unchanged) if the fit is no likelier than that
        hypothesis or too few draws start."""
        best = self.likeliest()
        if best is None or not self._history:
            return False
        free, low, span = self.free_unknowns()
        base = self.theta[best]

        def hypothesis(z: np.ndarray) -> np.ndarray:
            theta = base.copy()
            theta[free] = low + np.clip(z, 0.0, 1.0) * span
            return theta
        fit = laplace_fit(lambda z: self._residuals(hypothesis(z)), (base[free] - low) / span,
                          int(self.refine_evaluations))
        self.refinements += 1
        if fit is None:
            return False
        self.last_fit_cost = fit.cost
        if -fit.cost <= self.ll[best]:
            return False
        n = len(self.states)
        theta, states, ll, observations = [], [], [], []
        for z in fit.draw_inside(self._rng, 3 * n, float(self.refine_inflation)):
            state, full = self._start(self._bench_of(hypothesis(z)))
            if state is None:
                continue
            theta.append(full)
            states.append(state)
            ll.append(self._replay(state))
            observations.append(self._obs.copy())
            if len(states) == n:
                break
        ll = np.array(ll)
        if len(states) < n // 2 or not np.isfinite(ll).any():
            return False
        z = (np.array(theta)[:, free] - low) / span
        log_w = ll - fit.log_density(z, float(self.refine_inflation))
        self.theta, self.states, self.ll = np.array(theta), states, ll
        self.observations = np.array(observations)
        self.alive = np.isfinite(ll)
        self.log_w = np.where(self.alive, log_w - np.max(log_w, where=self.alive, initial=-math.inf), -math.inf)
        self.refined += 1
        return True

    def update(self, action: np.ndarray, obs: np.ndarray) -> None:
        """Advance every hypothesis by the period the bench just ran with ``action`` and weigh it by ``obs``."""
        self.observe(np.array(action, dtype=np.float64), np.array(obs[B_RANGE:B_RANGE + 9], dtype=float))

    @property
    def history(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Every period so far: the command sent and the rangefinders' nine displacements measured after it."""
        return list(self._history)

    def deviations(self) -> np.ndarray:
        """Each hypothesis's deviation from its own case-C reference now and that reference's slope, ``(n, 12)``:
        :func:`envs.core.reference_deviation` of its own state observation, as the env computes the truth's."""
        refs = np.array([s.ref for s in self.states])
        return reference_deviation(self.observations, refs, self._env.config.travel_m)

    def deviation(self, min_ess: float = 1.0) -> np.ndarray:
        """The bank's estimate of the bench's reference deviation (12 values): :meth:`deviations` averaged with the
        bank's weights, tempered to an effective size of at least ``min_ess`` (as :meth:`best` tempers them: a
        finite bank soon puts all its weight on one hypothesis, which is not the bench)."""
        return self._tempered(float(min_ess)) @ self.deviations()

    def reference(self) -> np.ndarray:
        """The hypotheses' case-C reference (displacements of CP1-CP3 at equal steps of travel, the env's table),
        averaged with the bank's weights: what the bank believes the bench's own reference is."""
        return np.einsum("i,ijk->jk", self.weights(), np.array([s.ref for s in self.states]))

    def observe(self, raw: np.ndarray, measured: np.ndarray) -> None:
        """:meth:`update` with the command and the nine measured displacements given directly."""
        self.predict(raw)
        self.weigh(measured)

    def predict(self, raw: np.ndarray) -> None:
        """:meth:`observe`'s first half, which needs no measurement: every live hypothesis advanced by the command
        ``raw`` the bench is running (its observation kept); :meth:`weigh` then takes the period's measurement. A
        controller runs it once the command is sent, in the period's slack, so that its next decision only weighs
        (:meth:`observe` is the two halves)."""
        self._predicted = np.array(raw, dtype=np.float64)
        self._ended = np.zeros(len(self.states), dtype=bool)
        for i, s in enumerate(self.states):
            if self.alive[i]:
                self._ended[i] = self._step(s, self._predicted)
                self.observations[i] = self._obs

    def weigh(self, measured: np.ndarray) -> None:
        """:meth:`observe`'s second half: weigh the hypotheses :meth:`predict` advanced by the nine displacements
        ``measured`` after that period."""
        if self._predicted is None:
            raise RuntimeError("SpecimenBank.weigh: no predicted period to weigh (call predict(raw) first)")
        measured = np.asarray(measured, dtype=float)
        self._history.append((self._predicted, measured))
        self._predicted = None
        for i in np.flatnonzero(self.alive):
            inc = self._log_likelihood(bool(self._ended[i]), self.observations[i], measured)
            self.log_w[i] += inc
            self.ll[i] += inc
            self.alive[i] = math.isfinite(self.log_w[i])
        self._settle()

    def _settle(self) -> None:
        """After a period's weighing: the refinement, the fallback to the prior if the bank diverged, or a move."""
        self.diverged = False
        moving = self.move_periods <= 0 or len(self._history) <= self.move_periods  # (module docstring)
        if moving and self.refine_every > 0 and len(self._history) % int(self.refine_every) == 0:
            self.refine()
        if not self.alive.any() or not self._healthy():
            self.fallbacks += 1
            self.diverged = True
            self.alive[:] = np.array([np.all(np.isfinite(s.y)) for s in self.states])
            self.log_w[:] = np.where(self.alive, 0.0, -math.inf)
            self.ll[:] = self.log_w
            self._counted_from = len(self._history)
        elif moving and self.jitter > 0 and self.ess() < self.rejuvenate_ess * len(self.states):
            if self.move == "mh":
                self._resample_move()
            else:
                self._rejuvenate()

    def ess(self) -> float:
        w = self.weights()
        return 1.0 / float(w @ w)

    def _rejuvenate(self) -> None:
        """Resample-move: the least likely half of the bank is replaced by perturbed copies of hypotheses drawn by
        their weights (a Gaussian kernel ``jitter`` times the bank's weighted spread, at least its spacing, kept in
        the prior's ranges), each run from its own start with the commands sent so far and weighed by every
        measurement so far; a copy that ends the test or does not start is not taken. So the bank refines around
        what the data say instead of collapsing onto the one hypothesis of its first draw that fits best."""
        w = self.weights()
        mean = w @ self.theta
        spread = np.sqrt(np.maximum(w @ (self.theta - mean) ** 2, 0.0))
        spread[self.circular] = 0.0  # a horizontal plane's direction: only its spacing (below)
        spacing = (self.high - self.low) / len(self.states)
        sigma = np.maximum(self.jitter * spread, spacing)
        if not self.vary_geometry:
            sigma[len(PARAMETERS):] = 0.0
        order = np.argsort(self.log_w)
        slots = order[:len(self.states) // 2]
        parents = np.searchsorted(np.cumsum(w), (np.arange(len(slots)) + self._rng.random()) / len(slots))
        parents = np.minimum(parents, len(w) - 1)
        for slot, parent in zip(slots, parents):
            theta = self.theta[parent] + sigma * self._rng.standard_normal(len(sigma))
            theta = np.where(self.circular, np.mod(theta, 360.0), np.clip(theta, self.low, self.high))
            state, full = self._start(self._bench_of(theta))
            if state is None:
                continue
            ll = 0.0
            for raw, measured in self._history:
                ll += self._advance(state, raw, measured)
                if not math.isfinite(ll):
                    break
            if math.isfinite(ll) and (not self.alive[slot] or ll > self.log_w[slot]):
                self.theta[slot], self.states[slot], self.log_w[slot], self.alive[slot] = full, state, ll, True
                self.ll[slot], self.observations[slot] = ll, self._obs
        self.rejuvenations += 1

    def _proposal(self) -> np.ndarray:
        """The random walk's Cholesky factor: ``jitter`` times the bank's weighted covariance (the posterior's
        shape, so that correlated unknowns such as the tip and the contact friction move together) plus the bank's
        spacing on the diagonal (a floor once the bank has narrowed); a horizontal plane's direction (an angle around
        the circle) moves by its spacing only; without ``vary_geometry`` the geometry stays the prior's."""
        w = self.weights()
        d = self.theta - w @ self.theta
        cov = (d * w[:, None]).T @ d
        free = ~self.circular
        if not self.vary_geometry:
            free[len(PARAMETERS):] = False
        cov[~free, :] = 0.0
        cov[:, ~free] = 0.0
        spacing = (self.high - self.low) / len(self.states)
        if not self.vary_geometry:
            spacing[len(PARAMETERS):] = 0.0
        moving = spacing > 0.0  # (a parameter fixed by its interval stays)
        cov[~moving, :] = 0.0
        cov[:, ~moving] = 0.0
        cov = self.jitter ** 2 * cov + np.diag(spacing ** 2)
        factor = np.zeros_like(cov)
        factor[np.ix_(moving, moving)] = np.linalg.cholesky(cov[np.ix_(moving, moving)])
        return factor

    def _resample_move(self) -> None:
        """Resample-move that keeps the bank a sample of the posterior given every measurement so far (Gilks &
        Berzuini 2001): the bank is resampled by weight (systematic), then each hypothesis takes ``move_steps``
        Metropolis-Hastings steps whose target is that posterior: a symmetric random-walk proposal
        (:meth:`_proposal`) run from its own start with every command sent so far, accepted with probability
        ``min(1, L(new) prior(new) / (L(old) prior(old)))``. v1 draws its unknowns uniformly within their ranges
        (:func:`envs.triplanar_shear_v1.draw_bench`) among the specimens that start, so the prior ratio is 1 inside
        the ranges for a proposal that starts and 0 otherwise (rejected). The weights are then equal."""
        n = len(self.states)
        factor = self._proposal()
        w = self.weights()
        parents = np.minimum(np.searchsorted(np.cumsum(w), (np.arange(n) + self._rng.random()) / n), n - 1)
        theta, ll = self.theta[parents].copy(), self.ll[parents].copy()
        states = [self.states[i].copy() for i in parents]
        observations = self.observations[parents]
        for _ in range(self.move_steps):
            for i in range(n):
                new = theta[i] + factor @ self._rng.standard_normal(len(theta[i]))
                new = np.where(self.circular, np.mod(new, 360.0), new)
                self.proposed += 1
                if np.any(new < self.low) or np.any(new > self.high):
                    continue  # outside the prior's ranges: prior density 0
                state, full = self._start(self._bench_of(new))
                if state is None:
                    continue  # friction holds it at rest: not in the prior (the bench's block started)
                new_ll = self._replay(state)
                if math.isfinite(new_ll) and math.log(self._rng.random()) < new_ll - ll[i]:
                    theta[i], states[i], ll[i], observations[i] = full, state, new_ll, self._obs
                    self.accepted += 1
        self.theta, self.states, self.ll, self.observations = theta, states, ll, observations
        self.log_w, self.alive = np.zeros(n), np.ones(n, dtype=bool)
        self.rejuvenations += 1

    def weights(self) -> np.ndarray:
        if not self.alive.any():
            return np.full(len(self.states), 1.0 / len(self.states))
        w = np.exp(self.log_w - np.max(self.log_w[self.alive]))
        w[~self.alive] = 0.0
        return w / w.sum()

    def _healthy(self) -> bool:
        mean, cov = self.mean_cov()
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            return False
        varied = self.resolution > 0.0  # a parameter fixed by its interval has no spread: not a divergence
        return bool(np.all(np.linalg.eigvalsh(cov[np.ix_(varied, varied)]) > 0.0))

    def mean_cov(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean and covariance of the parameters, the bank's spacing added (it bounds the resolution)."""
        w = self.weights()
        theta = self.theta[:, :N_REPORTED]
        mean = w @ theta
        d = theta - mean
        return mean, (d * w[:, None]).T @ d + np.diag(self.resolution ** 2)

    def interval(self, k: int = 0, z: float = 1.96) -> tuple[float, float]:
        """The 95 % interval of parameter ``k`` (Gaussian from :meth:`mean_cov`)."""
        mean, cov = self.mean_cov()
        half = z * math.sqrt(cov[k, k])
        return float(mean[k] - half), float(mean[k] + half)

    def best(self, count: int, min_ess: float = 1.0) -> tuple[list[BenchState], np.ndarray]:
        """Up to ``count`` hypotheses to plan with (copies of their states) and their weights: picked by systematic
        resampling (the likely ones when the weights are peaked, a spread of the prior while they are flat, so
        the first plans are robust to what is not yet known), each weighted by how often it was picked. The
        weights are tempered (``w ** beta``, the largest ``beta <= 1`` that leaves an effective sample size of at
        least ``min_ess``): the bank is finite and the bench is none of its hypotheses exactly, so a
        planner that trusted a single hypothesis would plan for a specimen that is not there."""
        w = self._tempered(min_ess)
        picks = np.searchsorted(np.cumsum(w), (np.arange(count) + 0.5) / count)
        picks = np.minimum(picks, len(w) - 1)
        chosen, counts = np.unique(picks, return_counts=True)
        return [self.states[i].copy() for i in chosen], counts / counts.sum()

    def ahead(self, states: list[BenchState], weights: np.ndarray,
              commands: np.ndarray) -> tuple[list[BenchState], np.ndarray]:
        """Copies of ``states`` (as :meth:`best` gives them; left as they were) carried through ``commands`` (periods
        x 2: the commands already decided for the coming periods), with their ``weights``: where each hypothesis
        will be when a plan made now takes over. One that ends the test on the way is dropped (nothing is left to
        plan for it); if all do, ``states`` and ``weights`` are returned as given. Counted in :meth:`work_counts`."""
        raws = np.asarray(commands, dtype=float)
        moved, kept = [], []
        for s, w in zip(states, weights):
            ahead = s.copy()
            if not any(self._step(ahead, raw) for raw in raws):
                moved.append(ahead)
                kept.append(w)
        if not moved:
            return states, weights
        w = np.asarray(kept, dtype=float)
        return moved, w / w.sum()

    def _tempered(self, min_ess: float) -> np.ndarray:
        w = self.weights()
        if min_ess <= 1.0 or 1.0 / float(w @ w) >= min_ess or self.alive.sum() <= 1:
            return w
        lw = np.where(self.alive, self.log_w - np.max(self.log_w[self.alive]), 0.0)

        def tempered(beta: float) -> np.ndarray:
            t = np.where(self.alive, np.exp(beta * lw), 0.0)  # the ruled-out stay out at any beta
            return t / t.sum()
        low, high = 0.0, 1.0
        for _ in range(30):  # bisection on beta: the effective sample size falls as beta grows
            beta = 0.5 * (low + high)
            t = tempered(beta)
            low, high = (beta, high) if 1.0 / float(t @ t) >= min_ess else (low, beta)
        return tempered(low)
