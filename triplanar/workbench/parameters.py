"""One object per fitted parameter: what a fit may do with it and what it found (after lmfit's ``Parameter``).

A :class:`FitParameter` carries, on one object, the recipe of one parameter of one effect (``vary``: whether the
fit moves it; ``min``/``max``: the plausible range it may move over; ``start``; ``per_test``: its own value in
every test; ``grid``: its coarse scan before polishing; ``snap``) and, once fitted, the result (``value``, ``stderr``,
``ci95``, ``status``, ``at_bound``). The recipe
defaults come from the effect's :class:`~triplanar.effects.Parameter` (its physical bounds, neutral value, fit
range), through :meth:`~triplanar.workbench.candidates.Candidate.parameters`; a recipe edited parameter by
parameter becomes a candidate again with :meth:`~triplanar.workbench.candidates.Candidate.from_parameters`::

    params = default_candidate("end_friction").parameters()
    params["phi_deg"] = params["phi_deg"].fixed(5.0)             # hold it at 5 deg
    params["phi_deg"] = params["phi_deg"].freed(0.0, 15.0)       # or free it over 0-15 deg

:class:`~triplanar.workbench.fit.EffectFit` reports its result as ``parameters_`` (``{effect: {param:
FitParameter}}``, :data:`EffectParameters`); its ``params_``, ``stderr_``, ``ci95_``, ``status_``, ``at_bound_`` and
``profile_ci95_`` are views of it, and so are the report dictionaries of each step of a fit
(:class:`~triplanar.workbench.results.FitStep`, :class:`~triplanar.workbench.select.SelectionStep`). A
:class:`~triplanar.workbench.candidates.Candidate` holds its recipe as FitParameter objects (``recipe``), and each
entry of a diagnosis (:class:`~triplanar.workbench.sweep.CandidateResult`) its result (``parameters``, with the
named entry's ``profile_ci95`` and ``model_ci95``).

Statuses: ``fitted`` (an interval), ``fixed`` (held), ``not_moved`` (never left its start), ``degenerate`` (the
data do not pull on it), ``unidentified`` (its interval spans the whole range), ``at_bound`` (fitted to an end of
its range: implausible), ``per_test`` (one value per test, no shared interval), ``unfitted`` (a recipe, not yet
fitted). :mod:`triplanar.workbench.intervals` says how the interval and its status are found.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from typing import Any

from ..effects import REGISTRY, EffectError, Parameter

__all__ = ["EffectParameters", "FitParameter", "STATUSES", "at_bound_of", "intervals_of", "listed", "profiles_of",
           "shared_values", "standard_errors", "statuses_of"]

STATUSES = ("unfitted", "fitted", "fixed", "not_moved", "degenerate", "unidentified", "at_bound", "per_test")


@dataclass(frozen=True)
class FitParameter:
    """One parameter of one effect in a fit: recipe and result (module doc).

    Attributes:
        effect, name: the effect's registered name and the parameter's (``qualified``: ``effect.name``).
        value: the fitted value (a recipe: the start; a held parameter: the value it is held at).
        vary: whether the fit moves it.
        min, max: the range the fit may move it over (within the effect's physical bounds).
        start: where the fit starts.
        per_test: fitted for each test (its shared ``value`` is then the start; ``per_test_values`` by test).
        stderr, ci95, status, at_bound: the fit's standard error, 95 % interval ``(low, high)``, status
            (``STATUSES``) and whether it ended at an end of its range.
        profile_ci95, model_ci95: a diagnosis's named entry only: the profile-likelihood interval
            (:mod:`~triplanar.workbench.profile`) and the one that admits model-form error
            (:mod:`~triplanar.workbench.alternatives`), ``None`` where there is none.
        per_test_values: a per-test parameter's fitted value in each test (``{test_id: value}``).
        grid: the coarse scan over its range before polishing: a number of evenly spaced points, or the values
            themselves. A shared parameter's is scanned when it is the only free parameter of its recipe (``None``
            or 0: no scan); a per-test parameter's is its scan in each test (``None``: the effect's
            ``Parameter.grid``, else 12 points).
        snap: a fitted value closer than this to the start is set to the start (a parameter whose small values are
            unresolvable, or that the core integrates badly, like a rise time of microseconds); 0: none.
    """

    effect: str
    name: str
    value: float
    vary: bool = True
    min: float = -math.inf
    max: float = math.inf
    start: float | None = None
    per_test: bool = False
    stderr: float | None = None
    ci95: tuple[float, float] | None = None
    status: str = "unfitted"
    at_bound: bool = False
    profile_ci95: tuple[float, float] | None = None
    model_ci95: tuple[float, float] | None = None
    per_test_values: dict[str, float] | None = field(default=None, compare=False)
    grid: int | tuple[float, ...] | None = None
    snap: float = 0.0

    def __post_init__(self) -> None:
        spec = self.spec
        if self.status not in STATUSES:
            raise ValueError(f"parameter {self.qualified}: status {self.status!r} is not one of {', '.join(STATUSES)}")
        for what, v in (("value", self.value), ("min", self.min), ("max", self.max)):
            if isinstance(v, bool) or not isinstance(v, numbers.Real) or math.isnan(v) and what != "value":
                raise EffectError(f"parameter {self.qualified}: {what} = {v!r} is not a number")
        if self.vary:
            if not spec.lower <= self.min < self.max <= spec.upper:
                raise EffectError(f"parameter {self.qualified}: fit range ({self.min}, {self.max}) must lie within "
                                  f"the effect's bounds [{spec.lower}, {spec.upper}] {spec.unit}")
            if not self.per_test and not self.min <= self.value <= self.max:
                raise EffectError(f"parameter {self.qualified}: value {self.value} is outside its fit range "
                                  f"({self.min}, {self.max})")
        if self.per_test and not self.vary:
            raise EffectError(f"parameter {self.qualified}: a per-test parameter is fitted (vary=True)")
        if self.snap < 0 or not math.isfinite(self.snap):
            raise EffectError(f"parameter {self.qualified}: snap {self.snap!r} must be a finite number >= 0")
        if self.start is not None and not spec.lower <= self.start <= spec.upper:
            raise EffectError(f"parameter {self.qualified}: start {self.start} is outside [{spec.lower}, "
                              f"{spec.upper}] {spec.unit}")

    @classmethod
    def held(cls, effect: str, name: str, value: float) -> FitParameter:
        """Parameter ``effect.name`` held at ``value`` (status ``fixed``; its range: the effect's physical bounds)."""
        spec = cls(effect, name, float(value), False, status="fixed").spec      # (names checked there)
        return cls(effect, name, float(value), False, spec.lower, spec.upper, status="fixed")

    @property
    def spec(self) -> Parameter:
        """The effect's own description of the parameter (physical bounds, unit, meaning)."""
        if self.effect not in REGISTRY:
            raise EffectError(f"unknown effect {self.effect!r}; known effects: {', '.join(sorted(REGISTRY))}")
        params = REGISTRY[self.effect].parameters
        if self.name not in params:
            raise EffectError(f"effect {self.effect!r} has no parameter {self.name!r} "
                              f"(its parameters: {', '.join(params) or 'none'})")
        return params[self.name]

    @property
    def qualified(self) -> str:
        return f"{self.effect}.{self.name}"

    @property
    def bounds(self) -> tuple[float, float]:
        return self.min, self.max

    @property
    def shared(self) -> bool:
        """Fitted with one value for all tests."""
        return self.vary and not self.per_test

    def fixed(self, value: float | None = None) -> FitParameter:
        """This parameter held at ``value`` (default: its current value); the fit does not move it."""
        v = self.value if value is None else float(value)
        spec = self.spec
        if not spec.lower <= v <= spec.upper:
            raise EffectError(f"parameter {self.qualified}: {v} is outside [{spec.lower}, {spec.upper}] {spec.unit}")
        return replace(self, value=v, vary=False, per_test=False, start=None, stderr=None, ci95=None,
                       status="fixed", at_bound=False, profile_ci95=None, model_ci95=None,
                       per_test_values=None)

    def freed(self, min: float | None = None, max: float | None = None, start: float | None = None) -> FitParameter:
        """This parameter moved by the fit over ``min``-``max`` (default: its range if it varies already, else
        the effect's fit range around the start), from ``start`` (default: its current value, or the effect's
        start if that is unset, clipped into the range)."""
        spec = self.spec
        s0 = float(start) if start is not None else self.value if math.isfinite(self.value) else spec.start_value
        lo, hi = self.bounds if self.vary else spec.fit_range(s0)
        lo, hi = (lo if min is None else float(min)), (hi if max is None else float(max))
        s = s0 if start is not None else min_max(s0, lo, hi)
        return replace(self, value=s, vary=True, min=lo, max=hi, start=s, stderr=None, ci95=None,
                       status="unfitted", at_bound=False, profile_ci95=None, model_ci95=None, per_test_values=None)

    def to_json(self) -> dict[str, Any]:
        return {"value": self.value, "vary": self.vary, "min": self.min, "max": self.max, "start": self.start,
                "per_test": self.per_test, "stderr": self.stderr,
                "ci95": list(self.ci95) if self.ci95 is not None else None, "status": self.status,
                "at_bound": self.at_bound,
                **({"profile_ci95": list(self.profile_ci95)} if self.profile_ci95 is not None else {}),
                **({"model_ci95": list(self.model_ci95)} if self.model_ci95 is not None else {}),
                **({"per_test_values": dict(self.per_test_values)} if self.per_test_values is not None else {})}

    def __str__(self) -> str:
        if not self.vary:
            return f"{self.qualified} = {self.value:.4g} (fixed)"
        interval = f" [{self.ci95[0]:.4g}, {self.ci95[1]:.4g}]" if self.ci95 is not None else ""
        return f"{self.qualified} = {self.value:.4g}{interval} ({self.status}; range {self.min:.4g}-{self.max:.4g})"


def min_max(v: float, lo: float, hi: float) -> float:
    return min(max(v, lo), hi)


#: the parameters of several effects, ``{effect: {param: FitParameter}}`` in fit order (a fit's, a step's): the
#: lmfit ``Parameters`` of a model with several effects
EffectParameters = dict[str, dict[str, FitParameter]]


def listed(interval: tuple[float, float] | None) -> list[float] | None:
    """An interval in the JSON report's form (a list, or ``None``)."""
    return list(interval) if interval is not None else None


# -- the report's dictionaries (``{effect: {param: ...}}``, as fit.json holds them) of EffectParameters -------------

def shared_values(params: EffectParameters) -> dict[str, dict[str, float]]:
    """``{effect: {param: value}}`` of the held and shared parameters (a per-test one has no shared value)."""
    return {e: {k: p.value for k, p in ps.items() if not p.per_test} for e, ps in params.items()}


def standard_errors(params: EffectParameters) -> dict[str, dict[str, float]]:
    """``{effect: {param: standard error}}`` of the parameters that have one (effects without any left out)."""
    out = {e: {k: p.stderr for k, p in ps.items() if p.stderr is not None} for e, ps in params.items()}
    return {e: v for e, v in out.items() if v}


def _free_shared_first(ps: dict[str, FitParameter]) -> list[tuple[str, FitParameter]]:
    return [(k, p) for k, p in ps.items() if p.shared] + [(k, p) for k, p in ps.items() if p.per_test]


def intervals_of(params: EffectParameters) -> dict[str, dict[str, list[float] | None]]:
    """``{effect: {param: [low, high] or None}}`` of the free parameters, the shared ones first (per-test: ``None``)."""
    return {e: {k: listed(p.ci95) for k, p in _free_shared_first(ps)} for e, ps in params.items()}


def statuses_of(params: EffectParameters) -> dict[str, dict[str, str]]:
    """``{effect: {param: status}}``: the free parameters (shared first), then the held ones."""
    return {e: {k: p.status for k, p in (*_free_shared_first(ps), *((k, p) for k, p in ps.items() if not p.vary))}
            for e, ps in params.items()}


def at_bound_of(params: EffectParameters) -> tuple[str, ...]:
    """``effect.param`` of the free parameters fitted to an end of their range (implausible)."""
    return tuple(p.qualified for ps in params.values() for p in ps.values() if p.vary and p.at_bound)


def profiles_of(params: EffectParameters) -> dict[str, dict[str, list[float] | None]]:
    """``{effect: {param: [low, high] or None}}``: the free parameters' profile-likelihood intervals."""
    return {e: {k: listed(p.profile_ci95) for k, p in ps.items() if p.vary} for e, ps in params.items()}
