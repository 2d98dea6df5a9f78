"""Picklable descriptions of a user's model and of one unit of work, and the pure function that does it.

Everything a sweep needs is expressed as a *task* (plain data: a :class:`ModelSpec`, a force, the measured
tests at that force) and a pure function (:func:`evaluate`) that turns a task into a result. Tasks are
mapped over by any executor that has ``map(fn, iterable)`` (see :mod:`triplanar.workbench.executor`), so
the same sweep runs in this process, in a local process pool or, later, on a Ray cluster.

Effects travel by name and parameter values (``("end_friction", (("phi_deg", 8.0),))``) and are rebuilt
from :data:`triplanar.EFFECTS` on the worker, so a user-registered effect needs only to be registered
there too (with the default ``fork`` start method on Linux a pool inherits the parent's registry).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ..effects import REGISTRY, Effect, EffectError
from ..measurement import MeasuredTest
from ..model import Loading, Model, paper_model
from ..paths import travel
from ..result import SimulationResult
from ..simulate import simulate
from ..specimen import Foundation, Specimen, reference
from .discrepancy import TestDiscrepancy, discrepancy_group, group_by_force
from ..outcome import Outcome

EffectSpec = tuple[str, tuple[tuple[str, float], ...]]

#: Simulation settings of the workbench. ``max_rows`` bounds a pathological run (a chattering stick-slip
#: start) so that one bad parameter vector costs about a second instead of minutes. ``rtol = 1e-7`` moves
#: the paths by less than 1e-4 mm from the core's default 1e-9 (far below a rangefinder's noise) and halves
#: the integrator's steps.
SIM_OPTIONS: dict[str, float] = {"max_rows": 60_000, "t_max_s": 5.0, "rtol": 1e-7, "atol": 1e-10}
#: The model is simulated this much further than the longest measured travel at its load (m).
TRAVEL_MARGIN_M = 0.005


@lru_cache(maxsize=1)
def _reference() -> tuple[Specimen, Foundation]:
    return reference()


def effect_spec(effect: Effect) -> EffectSpec:
    """An effect as (name, ((param, value), ...)), the picklable form."""
    return effect.name, tuple((k, float(v)) for k, v in effect.values.items())


def build_effect(spec: EffectSpec) -> Effect:
    name, values = spec
    if name not in REGISTRY:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[name](**dict(values))


@dataclass(frozen=True)
class ModelSpec:
    """The user's model without its force: a paper case, a specimen and foundation, and effects.

    ``specimen``/``foundation`` ``None`` mean the reference specimen. Build the model at one force with
    :meth:`build`; add effects with :meth:`with_effects`.
    """

    case: str = "B"
    effects: tuple[EffectSpec, ...] = ()
    specimen: Specimen | None = None
    foundation: Foundation | None = None

    @classmethod
    def from_effects(cls, effects: Iterable[Effect] = (), specimen: Specimen | None = None,
                     foundation: Foundation | None = None, case: str = "B") -> ModelSpec:
        return cls(case=case.upper(), effects=tuple(effect_spec(e) for e in effects), specimen=specimen,
                   foundation=foundation)

    def with_effects(self, effects: Iterable[Effect | EffectSpec]) -> ModelSpec:
        extra = tuple(e if isinstance(e, tuple) else effect_spec(e) for e in effects)
        return replace(self, effects=self.effects + extra)

    @property
    def effect_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.effects)

    def build_effects(self) -> list[Effect]:
        return [build_effect(s) for s in self.effects]

    def build(self, force_N: float) -> Model:
        """The model at ``force_N`` (what :func:`triplanar.paper_model` builds; validated)."""
        if self.specimen is None and self.foundation is None and self.case in ("A", "B", "C"):
            # paper_model would re-read the reference TOML on every call; the fits build thousands of models.
            specimen, foundation = _reference()
            model = Model(Loading(float(force_N), kind="hydrostatic" if self.case == "C" else "actuator",
                                  end_friction=self.case == "A"), specimen, foundation)
            model = model.with_effects(self.build_effects())
            model.validate()
            return model
        return paper_model(self.case, force_N, specimen=self.specimen, foundation=self.foundation,
                           effects=self.build_effects())

    @property
    def rest_positions(self) -> np.ndarray:
        """(3, 3) contact points at rest of this model's specimen."""
        return (self.specimen or _reference()[0]).contact_points_m

    def describe(self) -> str:
        base = {"A": "case A (end friction)", "B": "case B (bare actuator)", "C": "case C (hydrostatic)"}
        effects = [build_effect(s) for s in self.effects]
        ends = [e for e in effects if e.name == "end_friction"]
        if self.case == "B" and ends:
            # B plus end friction is the paper's case A (section 5.2); name it so, with the angle if not the specimen's
            own = (self.specimen or _reference()[0]).tip_friction_deg
            phi = ends[0]["phi_deg"]
            parts = ["case A (end friction)" if abs(phi - own) < 1e-9 else f"case A (end friction, phi_EF = {phi:g} deg)"]
            effects = [e for e in effects if e is not ends[0]]
        else:
            parts = [base.get(self.case, f"case {self.case}")]
        parts += [e.label() for e in effects]
        return " + ".join(parts)


@dataclass(frozen=True)
class EvalTask:
    """One unit of work: simulate ``spec`` at ``force_N`` and compare with ``tests`` (all at that force)."""

    spec: ModelSpec
    force_N: float
    tests: tuple[MeasuredTest, ...]
    keep_result: bool = False
    report: bool = True         # also what only reports need (arrival times, the threshold of a held model)


@dataclass(frozen=True)
class EvalResult:
    """What :func:`evaluate` returns: per-test discrepancies, the run's status, optionally the run."""

    force_N: float
    status: str
    message: str
    discrepancies: tuple[TestDiscrepancy, ...]
    threshold_N: float | None = None
    result: SimulationResult | None = field(default=None, repr=False)


def simulate_for(model: Model, tests: Sequence[MeasuredTest], rest: np.ndarray | None = None,
                 options: Mapping[str, Any] = SIM_OPTIONS) -> SimulationResult:
    """Simulate ``model`` (with ``options``, default :data:`SIM_OPTIONS`) far enough to cover the longest measured
    travel of ``tests``, measured from ``rest`` (default: the model's seated contact points, the origin the
    comparison measures travel from; a caller that has it already passes it)."""
    rest = model.seated_contact_points if rest is None else rest
    longest = max(float(np.max(travel(t.positions, rest))) for t in tests) if tests else 0.08
    return simulate(model, travel_m=max(longest, 0.0) + TRAVEL_MARGIN_M, **options)


def evaluate(task: EvalTask) -> EvalResult:
    """The pure evaluation function: build, simulate, compare. Never raises for a physical outcome: a
    model that holds the block, stops early or leaves a plane is reported in ``status`` and compared as far
    as it went (its last position stands in for the rest of the measured path)."""
    model = task.spec.build(task.force_N)
    tests = unread_tests(task.spec, task.tests)
    result = _simulate_cached(task.spec, model, tests)
    threshold = None
    if result.status is Outcome.HELD and task.report:
        from ..statics import sliding_threshold
        threshold = float(sliding_threshold(model))
    found = tuple(discrepancy_group(tests, result, task.report))
    return EvalResult(task.force_N, result.status.label, result.message, found, threshold,
                      result if task.keep_result else None)


def unread_tests(spec: ModelSpec, tests: Sequence[MeasuredTest]) -> tuple[MeasuredTest, ...]:
    """``tests`` as the instruments of ``spec`` would have recorded them had they been right: every instrument
    effect's :meth:`~triplanar.effects.Effect.unread` applied (the model predicts the true motion)."""
    readers = [e for e in spec.build_effects() if e.reads]
    if not readers:
        return tuple(tests)
    rest = spec.rest_positions
    out = []
    for test in tests:
        t_s, positions = test.t_s, test.positions
        for effect in reversed(readers):
            t_s, positions = effect.unread(t_s, positions, rest)
        out.append(replace(test, positions=positions, t_s=t_s))
    return tuple(out)


_SIMULATIONS: dict[tuple, tuple] = {}


def _simulate_cached(spec: ModelSpec, model: Model, tests: Sequence[MeasuredTest]) -> SimulationResult:
    """:func:`simulate_for`, remembered for the last few physics models in this process: effects that only change
    what is recorded (``read``) leave the simulation as it is, so a fit of one re-simulates nothing."""
    readers = {name for name, _ in spec.effects if REGISTRY[name].read is not Effect.read}
    if not readers:
        return simulate_for(model, tests)
    rest = model.seated_contact_points
    longest = round(max(float(np.max(travel(t.positions, rest))) for t in tests) if tests else 0.08, 3)
    physics = tuple(e for e in spec.effects if e[0] not in readers)
    # specimen and foundation by identity (they hold arrays); the entry keeps them alive, so an id is not reused
    key = (spec.case, physics, id(spec.specimen), id(spec.foundation), float(model.loading.force_N), longest)
    if key not in _SIMULATIONS:
        if len(_SIMULATIONS) >= 32:
            _SIMULATIONS.pop(next(iter(_SIMULATIONS)))
        result = simulate(model, travel_m=max(longest, 0.0) + 0.001 + TRAVEL_MARGIN_M, **SIM_OPTIONS)
        _SIMULATIONS[key] = (spec.specimen, spec.foundation, result)
    return _SIMULATIONS[key][2]


def tasks_for(spec: ModelSpec, tests: Sequence[MeasuredTest], keep_result: bool = False) -> list[EvalTask]:
    return [EvalTask(spec, f, group, keep_result) for f, group in group_by_force(tests).items()]


def spec_with_values(spec: ModelSpec, name: str, values: Mapping[str, float]) -> ModelSpec:
    """``spec`` plus effect ``name`` with ``values`` (other parameters at their defaults)."""
    clean = {k: float(v) for k, v in values.items() if math.isfinite(float(v))}
    return spec.with_effects([(name, tuple(sorted(clean.items())))])
