"""``mpc``: model-predictive control from the bench's observations.

Every period a bank of specimen hypotheses (:class:`agents.estimator.SpecimenBank`) takes the bench's measurements,
and every ``replan_every`` periods the cross-entropy planner (:class:`agents.planner.CEMPlanner`) optimises the action
sequence over rollouts of the env's own compiled step (:mod:`envs.prediction`: no second physics) from the
``hypotheses`` most likely hypotheses, each toward its own case-C reference path, weighted by their probabilities.
Between replans the controller follows its plan.

Why it is built as it is. Every setting was chosen on the tuning benches (stream ``agents.heldout.TUNING_SEED``), never
on the held-out ones; where it stands is in ``docs/actuator-study.md`` ("Controllers that use the model"), the rounds
of that choice, the variants tried and their numbers in ``docs/notes/mpc-tuning-rounds.md``.

* **The start** (``start_periods``, 8 periods = 40 ms) is a designed excitation instead of a plan while the estimator
  learns: plans made while the hypotheses still disagree lifted the block off or pushed it off a plane. The thrust is
  at ``1 + start_thrust`` times the load level and the tip offset at ``start_offset_m`` for one block of ``block``
  periods, then at ``1 - start_thrust`` and ``start_offset_ratio`` times the offset for the next (+10 % and -2 mm, then
  -10 % and +2 mm). Why it separates what a constant command does not (Galic, Glaser & Goodman 2008): the end
  friction is the tip's Coulomb force against its slip across the aft face, so a lateral stage motion turns it
  sideways and its yaw moment shows the tip friction, while the contact friction resists sliding in proportion to
  the normal forces and a thrust step shows it in the block's acceleration; under the nominal command the tip slips
  only by the face's own motion and the two are confounded. The offset goes to the negative side first (+2 mm first
  lifted the block off or pushed it off a plane within 3-5 periods on 10 of 60 tuning benches), and the second block
  mirrors it (holding it cost 0.26 mm of error). The start is followed like a plan, so the first real plan is made
  ``replan_every`` periods after the start's last period began: period 9.
* **Safety.** The thrust stays within ``1 +- thrust_envelope`` times the load level (0.7-1.3: a plan that pushes hard
  on a wrong hypothesis lifts the block off); a candidate whose smallest predicted normal reaction falls below
  ``normal_margin`` (0.1) of the normal load pays part of the failure penalty (:func:`envs.prediction.predict`); and
  the plans also answer, at ``guard_weight`` (0.1) of the total, to a pessimistic twin of the likeliest hypothesis
  (:meth:`MPCController._guarded`), since the lift-offs that remained came where the early bank put a high tip
  friction too low; as the bank sharpens, the twin joins the likeliest hypothesis. A margin from leaving a plane
  (``plane_margin_m``) is available and off: it cost error where the case-C path runs along a plane's edge.
* **Pace.** The block must keep up with the whole travel in ``pace_s`` (0.3 s): a slow block drifts from the
  hypotheses' paths for longer, and a short horizon lets it creep toward an arrest.
* **The planner** is ``limit``'s (horizon 48 periods, longer than the rest of the travel once the first plan is made,
  so no cost-to-go stands in for it; 64 candidates x 4 iterations), replanning every period. ``plan_delay`` > 0
  (off) models a planner run behind the decision: a plan made from a period's estimate takes over that many periods
  later, the commands already decided running until then (:meth:`MPCController._replan`).

* **Work budget** (``fev_budget`` 20,000 and ``decision_fev_budget`` 5e6 of the kernel's evaluations,
  :mod:`agents.planner`): a candidate's rollout ends once it has cost 20,000 evaluations (a period costs 13-70 where
  the block slides or sticks cleanly, thousands in a stiff state), and no further CEM iteration starts once the
  decision has cost 5 million, so a decision costs at most 5 million plus one iteration of candidates that each stop
  within a period of 20,000 (about 17 million evaluations, ~13 s of CPU here, if no period costs more than the
  stiffest seen, ~7,000; before, decisions of 85 s were seen on a held-out bench). Chosen on 60 tuning benches
  against no budget by the rule of ``move_periods`` below: score +0.005 mm (+0.000 to +0.015), 60/60 each, decision p99 3.9 s against 4.2 s, largest
  6.0 s against 11.4 s; a tighter one (5,000 and 1.9e6) lost a bench (59/60, +0.164 mm, -0.004 to +0.490) and was
  not taken (``docs/performance.md``).
* **Cost** (``move_periods``, 30). The bank resample-moves and refines, the two steps that replay the whole
  history, only in its first 30 periods, and is a plain particle filter after them, so that its update no longer
  grows with the episode's length, however long that runs (the plan's does not grow with it: its horizon is fixed).
  Chosen on 60 tuning benches against the unbounded bank (0, the setting before 2026-11-29, which the
  distillation labels' expert keeps): score +0.001 mm (-0.009 to +0.008), 60/60 successes each, 7 % less CPU per
  episode; 15 moved the score by +0.067 mm (+0.021 to +0.124) and was not taken (``docs/performance.md``).

What it does not reach: the perfect-knowledge ``limit``. One episode's measurements place the contact friction angles
and the mass centre only in combinations; on the tuning benches the error ``mpc`` adds to ``limit``'s equals, on
average, what its measurements leave of the block's deviation from its case-C path unknown
(``benchmarks/information_bound.py``).

The controller knows the bench's hardware (bandwidths, latency, noise: its fields, v1's defaults) and a prior
specimen (``prior``: the env's nominal specimen by default, or a ``Specimen``, or the path of a ``fit.json`` or
specimen TOML, :func:`triplanar.prior.load_prior`; a fit's 95 % intervals then bound the hypotheses of what it
fitted, e.g. the tip friction), never the bench's true specimen. Where the laboratory knows its tip's friction (a
design of the bench study, whose tip is fixed), ``tip_friction_deg`` holds every hypothesis at it.
After each ``act`` its :attr:`MPCController.info` holds the estimate (mean, tip-friction interval), whether the
estimator fell back to the prior this period (``estimator_fallback``) and how often in the episode, and the CPU
time of the decision. It never sends a non-finite action: if the plan is not finite it holds its last action and
says so (``info["held"]``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from envs.core import ShearConfig
from envs.triplanar_shear_v1 import DEFAULT_BENCH, nominal_command
from triplanar import kernel as K
from triplanar.prior import fitted_intervals, load_prior

from .controller_base import Controller
from .estimator import GEOMETRY, PARAMETERS, SpecimenBank
from .planner import CEMPlanner


@dataclass
class MPCController(Controller):
    """Estimator + receding-horizon planner (module docstring); the fields are its settings and the bench's
    known hardware."""

    name: str = "mpc"
    config: ShearConfig = field(default_factory=ShearConfig)
    load_N: float = 0.0
    bank_size: int = 32
    hypotheses: int = 6
    horizon: int = 48
    block: int = 4
    samples: int = 64
    iterations: int = 4
    elites: int = 6
    sigma0: float = 0.3
    replan_every: int = 1
    plan_delay: int = 0
    start_periods: int = 8
    pace_s: float = 0.3
    thrust_envelope: float = 0.3
    normal_margin: float = 0.1
    plane_margin_m: float = 0.0
    fev_budget: float = 20_000.0
    decision_fev_budget: float = 5e6
    guard_weight: float = 0.1
    ramp_periods: int = 0
    offset_envelope: float = 1.0
    min_ess: float = 3.0
    model_error_m: float = 2e-4
    vary_geometry: bool = True
    move: str = "mh"
    move_steps: int = 3
    refine_every: int = 10
    refine_evaluations: int = 30
    refine_inflation: float = 1.5
    move_periods: int = 30
    start_thrust: float = 0.1
    start_offset_m: float = -0.002
    start_offset_ratio: float = -1.0
    start_centre_m: float = 0.0
    seed: int = 0
    stage_bandwidth_hz: float = DEFAULT_BENCH.stage_bandwidth_hz
    thrust_bandwidth_hz: float = DEFAULT_BENCH.thrust_bandwidth_hz
    latency_s: float = DEFAULT_BENCH.latency_s
    sensor_noise_m: float = DEFAULT_BENCH.sensor_noise_m
    tip_friction_deg: float | None = None
    prior: Any = None
    info: dict = field(default_factory=dict)

    def reset(self, load_N: float, config: ShearConfig) -> None:
        self.config, self.load_N = config, float(load_N)
        self.bank = self.new_bank(load_N, config)
        self.planner = CEMPlanner.with_settings_of(self)
        self._periods = 0
        self._widen()
        self._plan: np.ndarray | None = None
        self._age = 0
        self._last = nominal_command(config)
        self._first = True
        self.info = {"estimator_fallback": False, "fallbacks": 0, "held": False, "cpu_s": 0.0}

    def new_bank(self, load_N: float, config: ShearConfig) -> SpecimenBank:
        """The estimator of an episode at ``load_N`` on the bench of ``config``, with this controller's settings
        (its size, moves, refinement, the prior and the bench's known hardware), reset."""
        specimen, foundation = config.base_specimen()
        prior = self.prior if self.prior is not None else specimen
        intervals = {}
        if isinstance(prior, (str, Path)):  # a fit: its specimen, and its intervals narrow the hypotheses
            intervals = fitted_intervals(prior)
            prior = load_prior(prior, specimen, foundation)
        if self.tip_friction_deg is not None:  # a tip the laboratory knows (a design's): every hypothesis holds it
            intervals["tip_friction_deg"] = (float(self.tip_friction_deg),) * 2
        shear = {f: getattr(config, f) for f in ShearConfig.__dataclass_fields__ if f not in ("specimen", "foundation")}
        env_kwargs = {**shear, "specimen": prior, "foundation": foundation, "observation_mode": "state",
                      "stage_bandwidth_hz": self.stage_bandwidth_hz, "thrust_bandwidth_hz": self.thrust_bandwidth_hz,
                      "latency_s": self.latency_s, "sensor_noise_m": 0.0}
        bank = SpecimenBank(prior, foundation, env_kwargs, int(self.bank_size), int(self.seed),
                            float(self.sensor_noise_m), float(self.model_error_m), intervals,
                            bool(self.vary_geometry), move=str(self.move), move_steps=int(self.move_steps),
                            refine_every=int(self.refine_every), refine_evaluations=int(self.refine_evaluations),
                            refine_inflation=float(self.refine_inflation), move_periods=int(self.move_periods))
        bank.reset(load_N)
        return bank

    def start_command(self, period: int, config: ShearConfig) -> np.ndarray:
        """The start's command at ``period`` (from 1): the nominal one, with the thrust at ``1 +- start_thrust`` times
        the load level, alternating every ``block`` periods, and the tip offset at ``start_centre_m`` plus
        ``start_offset_m`` in the first block of each pair and plus ``start_offset_ratio`` times that in the second
        (-1: mirrored; zero: constant). It depends on nothing measured (``benchmarks/start_drift.py`` replays it)."""
        first = ((period - 1) // int(self.block)) % 2 == 0
        thrust = 2.0 * self.start_thrust / config.thrust_scale
        offset = self.start_offset_m / config.offset_range_m
        step = np.array([thrust, offset]) if first else np.array([-thrust, self.start_offset_ratio * offset])
        step[1] += self.start_centre_m / config.offset_range_m
        return np.clip(nominal_command(config) + step, -1.0, 1.0)

    def _widen(self) -> None:
        """The planner's envelope this period: the thrust within ``1 +- thrust_envelope`` times the load level, the
        tip offset within ``+- offset_envelope`` of its range; with ``ramp_periods`` > 0 it opens linearly from the
        nominal command to that over as many periods after the start."""
        f = 1.0
        if self.ramp_periods > 0:
            f = min(1.0, max(self._periods - self.start_periods, 0) / float(self.ramp_periods))
        self.planner.low = (-self.thrust_envelope * f, -self.offset_envelope * f)
        self.planner.high = (self.thrust_envelope * f, self.offset_envelope * f)

    def _guarded(self, states: list, weights: np.ndarray) -> tuple[list, np.ndarray]:
        """The planning hypotheses with, at ``guard_weight`` of the total, a pessimistic twin of the most probable
        one: its tip friction at the top of the bank's 95 % interval (``phi_EF``, kernel ``P_TANEF``). End friction
        turned sideways by a lateral tip motion is what lifted the block off on benches whose tip friction the
        early bank underestimated; the twin makes a plan pay for that risk while the bank cannot rule it out. Where
        the laboratory knows its tip (``tip_friction_deg``) there is nothing to underestimate and no twin."""
        if self.guard_weight <= 0.0 or self.tip_friction_deg is not None:
            return states, weights
        twin = states[int(np.argmax(weights))].copy()
        twin.p[K.P_TANEF] = max(twin.p[K.P_TANEF], math.tan(math.radians(self.bank.interval(0)[1])))
        return states + [twin], np.append((1.0 - self.guard_weight) * np.asarray(weights), self.guard_weight)

    def _replan(self, states: list, weights: np.ndarray) -> np.ndarray:
        """The plan from this period: at once (``plan_delay`` 0), or, for a planner that runs behind the decision,
        the current plan's next ``plan_delay`` commands (already decided) and then a plan made from this period's
        estimate for the period it takes over, each hypothesis carried there through those commands
        (:meth:`SpecimenBank.ahead`): what a planner finishing ``plan_delay`` periods after its measurement sends."""
        delay = 0 if self._plan is None else min(int(self.plan_delay), len(self._plan) - self._age)
        if delay <= 0:
            return self.planner.plan(states, weights, self._last)
        committed = self._plan[self._age:self._age + delay]
        states, weights = self.bank.ahead(states, weights, committed)
        self.planner.advance(self._plan[self._age + delay - 1:])   # the warm start from the period it takes over
        return np.concatenate([committed, self.planner.plan(states, weights, committed[-1])])

    def act(self, obs: np.ndarray) -> np.ndarray:
        start = time.process_time()
        if not self._first:  # the observation of the period the last action ran
            self.bank.update(self._last, obs)
        self._first = False
        self._periods += 1
        planned = self._periods > self.start_periods and (
            self._plan is None or self._age >= min(self.replan_every, len(self._plan)))
        if self._periods <= self.start_periods:  # the start: a designed excitation while the data say little
            self._plan, self._age = np.repeat(self.start_command(self._periods, self.config)[None, :],
                                              int(self.horizon), axis=0), 0
        elif planned:
            self._widen()
            states, weights = self._guarded(*self.bank.best(int(self.hypotheses), float(self.min_ess)))
            self._plan = self._replan(states, weights)
            self._age = 0
        action = self._plan[self._age]
        self.planner.advance(self._plan[self._age:])
        self._age += 1
        held = not np.all(np.isfinite(action))
        if held:
            action = self._last
        self._last = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        mean, _ = self.bank.mean_cov()
        self.info = {"estimator_fallback": self.bank.diverged, "fallbacks": self.bank.fallbacks, "held": held,
                     "planned": planned,
                     "estimate": dict(zip(PARAMETERS + GEOMETRY, (float(v) for v in mean))),
                     "tip_friction_interval_deg": self.bank.interval(0),
                     "fevs": self.planner.last_fevs if planned else 0.0, "cpu_s": time.process_time() - start}
        return self._last.astype(np.float32)
