"""Candidate effects: which parameters of an effect a fit moves, within which plausible range, from where.

A candidate is an effect plus a fitting recipe. Every registered effect is a candidate, and its recipe comes
from the effect's own description (``triplanar/effects.py``): each :class:`~triplanar.effects.Parameter` says
whether a fit moves it (``free``), over which plausible range (``fit``/``fit_span``, else its bounds), from
where (:meth:`~triplanar.effects.Effect.fit_start`: the *neutral* value, where the effect does nothing) and,
for a one-parameter recipe, the coarse grid scanned before polishing (``grid``, else 7 points). The built-in
effects keep the number of free parameters small (every free parameter multiplies the cost of a fit and
weakens identifiability); their choices and reasons are next to their parameters in ``effects.py``, and
``docs/workbench.md`` tabulates them.

The start is never the value a dataset was made with. A fitted value at the edge of its range is
*implausible*: the data pushed past what the recipe considers physical, and diagnose does not name such a
candidate.

A user effect registered with :func:`triplanar.register` becomes a candidate the same way; with no fit
metadata, every parameter is free over its declared bounds, starting at its default (so give the default the
value at which the effect does nothing), and a one-parameter effect gets a grid of 7. Pass your own
:class:`Candidate` for anything else, or edit a recipe parameter by parameter (:meth:`Candidate.parameters`,
:meth:`Candidate.from_parameters`, :class:`~triplanar.workbench.parameters.FitParameter`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Iterable, Mapping

from ..effects import BUILTIN, REGISTRY, EffectError
from ..specimen import Specimen, reference
from .parameters import FitParameter

__all__ = ["BUILTIN", "Candidate", "builtin_candidates", "candidate_library", "default_candidate", "resolve"]


@dataclass(frozen=True, init=False)
class Candidate:
    """An effect and how to fit it.

    The recipe is one :class:`~triplanar.workbench.parameters.FitParameter` per parameter the recipe names
    (``recipe``): the ones that vary are free over their range (``min``/``max``) from their start (``value``: the
    start clipped into the range; ``start``: the start as given, ``None`` for the effect's default), per test or
    shared (``per_test``), with their coarse scan (``grid``) and ``snap``; the others are held at their ``value``
    (parameters not named: the effect's default). ``free``, ``bounds``, ``start``, ``fixed``, ``per_test``,
    ``grid``, ``snap`` and ``per_test_grid`` are views of it, and the constructor takes either those
    (``Candidate(effect, free, bounds, start, fixed, ...)``) or ``recipe=``.

    Attributes:
        effect: registered effect name.
        recipe: the parameters (above).

    Constructor args (instead of ``recipe``): ``free``: parameters the fit moves; ``bounds``: the fit (plausible)
    range of each; ``start``: start values (missing: the effect's default); ``fixed``: values of other parameters
    held (missing: the effect's default); ``grid``: a coarse grid scan before polishing, of the single shared
    free parameter (a number of evenly spaced points over its range, or the values themselves; 0: none; each
    shared free parameter carries it, and it is scanned while only one is free); ``snap``: ``{param: distance}``,
    fitted values closer than this to the start are set to it; ``per_test``: free parameters that take their own
    value in every test (the others are shared by all tests; a fit profiles them:
    :mod:`triplanar.workbench.pertest`); ``per_test_grid``: the scan of each per-test parameter in each test
    (missing: the effect's ``Parameter.grid``, else 12 points).
    """

    effect: str
    recipe: tuple[FitParameter, ...]

    def __init__(self, effect: str, free: Iterable[str] = (), bounds: Mapping[str, tuple[float, float]] | None = None,
                 start: Mapping[str, float] | None = None, fixed: Mapping[str, float] | None = None,
                 grid: int | tuple[float, ...] = 0, snap: Mapping[str, float] | None = None,
                 per_test: Iterable[str] = (), per_test_grid: Mapping[str, int | tuple[float, ...]] | None = None,
                 *, recipe: Iterable[FitParameter] | None = None) -> None:
        if effect not in REGISTRY:
            raise EffectError(f"unknown effect {effect!r}; known effects: {', '.join(sorted(REGISTRY))}")
        if recipe is None:
            recipe = _recipe(effect, tuple(free), bounds or {}, start, fixed or {}, tuple(per_test))
            recipe = _with_scans(effect, recipe, grid, snap or {}, per_test_grid or {})
        elif tuple(free) or bounds or start or fixed or tuple(per_test) or grid or snap or per_test_grid:
            raise TypeError(f"candidate {effect!r}: give the recipe either as recipe= (FitParameter objects, which "
                            f"carry their grid and snap) or as free/bounds/start/fixed/grid/snap/per_test/"
                            f"per_test_grid, not both")
        recipe = tuple(recipe)
        others = sorted({p.effect for p in recipe} - {effect})
        if others:
            raise EffectError(f"candidate {effect!r}: its recipe has a parameter of effect {others[0]!r}")
        names = [p.name for p in recipe]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise EffectError(f"parameter {effect}.{twice[0]} given twice")
        object.__setattr__(self, "effect", effect)
        object.__setattr__(self, "recipe", recipe)

    # -- views of the recipe ------------------------------------------------------------------------------
    @property
    def free(self) -> tuple[str, ...]:
        """The parameters the fit moves."""
        return tuple(p.name for p in self.recipe if p.vary)

    @property
    def bounds(self) -> dict[str, tuple[float, float]]:
        """The fit (plausible) range of each free parameter."""
        return {p.name: p.bounds for p in self.recipe if p.vary}

    @property
    def start(self) -> dict[str, float]:
        """The start values given (a free parameter without one starts at the effect's default)."""
        return {p.name: p.start for p in self.recipe if p.vary and p.start is not None}

    @property
    def fixed(self) -> dict[str, float]:
        """The values of the parameters the recipe holds."""
        return {p.name: p.value for p in self.recipe if not p.vary}

    @property
    def per_test(self) -> tuple[str, ...]:
        """The free parameters that take their own value in every test."""
        return tuple(p.name for p in self.recipe if p.per_test)

    @property
    def grid(self) -> int | tuple[float, ...]:
        """The coarse scan of the (first) shared free parameter (0: none); scanned while it is the only free one."""
        return next((p.grid or 0 for p in self.recipe if p.shared), 0)

    @property
    def snap(self) -> dict[str, float]:
        """``{param: distance}`` of the free parameters that snap to their start."""
        return {p.name: p.snap for p in self.recipe if p.vary and p.snap}

    @property
    def per_test_grid(self) -> dict[str, int | tuple[float, ...]]:
        """``{param: scan}`` of the per-test parameters given their own scan (the others: the effect's)."""
        return {p.name: p.grid for p in self.recipe if p.per_test and p.grid is not None}

    def with_parameters(self, parameters: Iterable[FitParameter]) -> Candidate:
        """This candidate with ``parameters`` in its recipe (each replacing the one of its name, else added)."""
        new = {p.name: p for p in parameters}
        recipe = [new.pop(p.name, p) for p in self.recipe] + list(new.values())
        return Candidate(self.effect, recipe=recipe)

    @property
    def shared(self) -> tuple[str, ...]:
        """The free parameters common to all tests (the free ones that are not per test)."""
        return tuple(p for p in self.free if p not in self.per_test)

    def with_per_test(self, names: Iterable[str]) -> Candidate:
        """This recipe with ``names`` (also) fitted per test (a parameter held by the recipe is freed)."""
        params = REGISTRY[self.effect].parameters
        names = list(names)
        for name in names:
            if name not in params:
                raise EffectError(f"per-test parameter {self.effect}.{name}: effect {self.effect!r} has no parameter "
                                  f"{name!r} (its parameters: {', '.join(params) or 'none'})")
        free = set(self.free)
        # a free one becomes per test where it is (scanned in each test with the effect's grid); a held one is freed
        # over the effect's fit range, after the free ones; with a per-test parameter no shared one is grid-scanned
        recipe = [replace(p, per_test=True, grid=None) if p.vary and p.name in names else
                  replace(p, grid=None) if p.shared else p for p in self.recipe if p.vary or p.name not in names]
        for n in dict.fromkeys(n for n in names if n not in free):
            lo, hi = params[n].fit_range(params[n].start_value)
            recipe.append(FitParameter(self.effect, n, _clip(params[n].default, lo, hi), True, lo, hi, per_test=True))
        return Candidate(self.effect, recipe=recipe)

    def per_test_grid_values(self, name: str, periodic: bool = False) -> list[float]:
        """The per-test scan of per-test parameter ``name`` (natural units); ``periodic``: over one period centred
        on its range, without repeating the end."""
        param = REGISTRY[self.effect].parameters[name]
        mine = next(p for p in self.recipe if p.name == name)
        spec = param.grid if mine.grid is None else mine.grid
        lo, hi = mine.bounds
        spec = 12 if spec is None else spec
        if periodic and param.period is not None and isinstance(spec, int):
            mid = 0.5 * (lo + hi)
            return [mid - 0.5 * param.period + param.period * i / spec for i in range(spec)]
        if isinstance(spec, int):
            return [lo + (hi - lo) * i / (spec - 1) for i in range(spec)] if spec > 1 else [lo]
        return [float(v) for v in spec]

    def start_values(self) -> dict[str, float]:
        """Where the fit starts each free parameter (its start, or the effect's default, clipped into its range)."""
        return {p.name: p.value for p in self.recipe if p.vary}

    def values(self, free_values: Mapping[str, float]) -> dict[str, float]:
        """All parameter values: fixed ones plus the given free ones (snapped, see ``snap``)."""
        free = {}
        for p in self.recipe:
            if p.vary:
                v = float(free_values[p.name])
                free[p.name] = p.value if abs(v - p.value) < p.snap else v
        return {**{k: float(v) for k, v in self.fixed.items()}, **free}

    def parameters(self) -> dict[str, FitParameter]:
        """The recipe as one :class:`~triplanar.workbench.parameters.FitParameter` per parameter of the effect
        (free ones with their range and start, the others held at their fixed value or the effect's default)."""
        mine = {p.name: p for p in self.recipe}
        out = {}
        for name, spec in REGISTRY[self.effect].parameters.items():
            p = mine.get(name)
            if p is not None and p.vary:
                out[name] = replace(p, start=p.value)
            else:
                value = float(p.value if p is not None else spec.default)
                out[name] = FitParameter.held(self.effect, name, value)
        return out

    @classmethod
    def from_parameters(cls, parameters: Iterable[FitParameter], grid: int | tuple[float, ...] | None = None,
                        snap: Mapping[str, float] | None = None) -> Candidate:
        """The candidate whose recipe the ``parameters`` of one effect describe (:meth:`parameters`, edited):
        the ones that vary are free over their range from their start, the others held at their value; a
        parameter not given keeps the effect's default. ``grid``: the constructor's (``None``: the parameters' own,
        and the effect's own for a single shared free parameter without one, else none); ``snap``: the
        constructor's (``None``: the parameters' own, else the effect's own)."""
        parameters = list(parameters)
        effects = {p.effect for p in parameters}
        if len(effects) != 1:
            raise EffectError(f"a candidate is one effect's parameters (given: {', '.join(sorted(effects)) or 'none'})")
        effect = effects.pop()
        names = [p.name for p in parameters]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise EffectError(f"parameter {effect}.{twice[0]} given twice")
        specs = REGISTRY[effect].parameters
        free = tuple(p.name for p in parameters if p.vary)
        per_test = tuple(p.name for p in parameters if p.per_test)
        one = len(free) == 1 and not per_test
        if grid is None:
            own = next((p.grid for p in parameters if p.shared and p.grid is not None), None)
            grid = own if own is not None else (7 if specs[free[0]].grid is None else specs[free[0]].grid) if one else 0
        if snap is None:
            snap = {p.name: p.snap or specs[p.name].snap for p in parameters if p.vary and (p.snap or specs[p.name].snap)}
        return cls(effect, free, {p.name: p.bounds for p in parameters if p.vary},
                   {p.name: p.value if p.start is None else p.start for p in parameters if p.vary},
                   fixed={p.name: p.value for p in parameters if not p.vary}, grid=grid, snap=snap,
                   per_test=per_test, per_test_grid={p.name: p.grid for p in parameters
                                                     if p.per_test and p.grid is not None})

    def grid_values(self) -> list[float]:
        """The grid scan's values of the (single) free parameter, in natural units ([] for none)."""
        free = [p for p in self.recipe if p.vary]
        if len(free) != 1 or free[0].per_test or not free[0].grid:
            return []
        (lo, hi), grid = free[0].bounds, free[0].grid
        if isinstance(grid, int):
            return [lo + (hi - lo) * i / (grid - 1) for i in range(grid)] if grid > 1 else [lo]
        return [float(v) for v in grid]


def default_candidate(name: str, specimen: Specimen | None = None) -> Candidate:
    """The recipe a registered effect describes (module doc), for ``specimen`` (default: the reference)."""
    if name not in REGISTRY:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(sorted(REGISTRY))}")
    cls = REGISTRY[name]
    params = cls.parameters
    start = cls.fit_start(specimen if specimen is not None else reference()[0])
    free = tuple(k for k, p in params.items() if p.free or p.per_test)
    per_test = tuple(k for k in free if params[k].per_test)
    grid: int | tuple[float, ...] = 0
    if len(free) == 1 and not per_test:
        spec = params[free[0]].grid
        grid = 7 if spec is None else spec
    return Candidate(name, free, {k: params[k].fit_range(start[k]) for k in free}, {k: start[k] for k in free},
                     fixed={k: p.default for k, p in params.items() if not (p.free or p.per_test)}, grid=grid,
                     snap={k: params[k].snap for k in free if params[k].snap}, per_test=per_test)


def builtin_candidates(specimen: Specimen | None = None) -> dict[str, Candidate]:
    """The built-in effects' recipes for ``specimen`` (default: the reference)."""
    return {name: default_candidate(name, specimen) for name in BUILTIN}


def screened_names() -> list[str]:
    """The effects ``diagnose`` tries when no candidates are named, in registration order: every registered effect
    that is screened (``Effect.screened``) but the given numbers, ``specimen``, which :mod:`triplanar.workbench.given`
    audits apart."""
    return [n for n, cls in REGISTRY.items() if cls.acts_on != "specimen" and cls.screened]


def candidate_library(names: Iterable[str] | None = None, exclude: Iterable[str] = (),
                      specimen: Specimen | None = None) -> list[Candidate]:
    """Candidates for ``names`` (default: :func:`screened_names`), minus ``exclude``."""
    names = screened_names() if names is None else list(names)
    skip = set(exclude)
    return [default_candidate(n, specimen) for n in names if n not in skip]


def resolve(candidates: Iterable[Candidate | str] | None, exclude: Iterable[str] = (),
            specimen: Specimen | None = None) -> list[Candidate]:
    """Normalise a user's candidate list (names or :class:`Candidate`), dropping excluded names."""
    if candidates is None:
        return candidate_library(None, exclude, specimen)
    skip = set(exclude)
    out: list[Candidate] = []
    candidates_seen: set[str] = set()
    for c in candidates:
        cand = c if isinstance(c, Candidate) else default_candidate(c, specimen)
        if cand in out or (isinstance(c, str) and c in candidates_seen):
            raise ValueError(f"candidate {cand.effect!r} given twice")
        if isinstance(c, str):
            candidates_seen.add(c)
        if cand.effect not in skip:
            out.append(cand)
    return out


def refit_candidate(name: str, given: Mapping[str, float], specimen: Specimen | None = None) -> Candidate:
    """The recipe of effect ``name`` for re-estimating the values the user *gave* it: the same free
    parameters, starting at the given values (the grid scan, if any, still runs and includes them); a fit
    range widened to contain each given value (within the effect's physical bounds)."""
    cand = default_candidate(name, specimen)
    params = REGISTRY[name].parameters
    edits = []
    for p in cand.recipe:
        if p.vary:
            s = float(given.get(p.name, p.value))
            lo, hi = max(params[p.name].lower, min(p.min, s)), min(params[p.name].upper, max(p.max, s))
            edits.append(replace(p, value=s, min=lo, max=hi, start=s))
    free = set(cand.free)
    edits += [FitParameter.held(name, k, v) for k, v in given.items() if k not in free]
    return cand.with_parameters(edits)


def without_effect(effects: tuple, name: str) -> tuple:
    """A ``ModelSpec.effects`` tuple without effect ``name``."""
    return tuple(e for e in effects if e[0] != name)


def _clip(v: float, lo: float, hi: float) -> float:
    return min(max(float(v), lo), hi)


def _with_scans(effect: str, recipe: list[FitParameter], grid: int | tuple[float, ...],
                snap: Mapping[str, float], per_test_grid: Mapping[str, int | tuple[float, ...]]) -> list[FitParameter]:
    """The keyword form's ``grid`` (on every shared free parameter), ``snap`` and ``per_test_grid`` (on the per-test
    parameters they name) put on the recipe's parameters."""
    names = {p.name: p for p in recipe}
    for name in per_test_grid:
        if name not in names or not names[name].per_test:
            raise EffectError(f"candidate {effect!r}: per_test_grid names {effect}.{name}, which is not a per-test "
                              f"parameter (per test: {', '.join(p.name for p in recipe if p.per_test) or 'none'})")
    for name in snap:
        if name not in names:
            raise EffectError(f"candidate {effect!r}: snap names {effect}.{name}, which the recipe does not name")
    scan = tuple(float(v) for v in grid) if not isinstance(grid, int) else grid
    return [replace(p, grid=scan if p.shared else _scan(per_test_grid.get(p.name)) if p.per_test else None,
                    snap=float(snap.get(p.name, 0.0))) for p in recipe]


def _scan(spec: int | Iterable[float] | None) -> int | tuple[float, ...] | None:
    return spec if spec is None or isinstance(spec, int) else tuple(float(v) for v in spec)


def _recipe(effect: str, free: tuple[str, ...], bounds: Mapping[str, tuple[float, float]],
            start: Mapping[str, float] | None, fixed: Mapping[str, float], per_test: tuple[str, ...]
            ) -> list[FitParameter]:
    """The recipe :class:`Candidate`'s keyword form describes, checked: names the effect has, a range within its
    bounds for every free parameter, per-test parameters among the free ones."""
    params = REGISTRY[effect].parameters
    for name in (*free, *fixed):
        if name not in params:
            raise EffectError(f"effect {effect!r} has no parameter {name!r} "
                              f"(its parameters: {', '.join(params) or 'none'})")
    for name in per_test:
        if name not in free:
            raise EffectError(f"candidate {effect!r}: per-test parameter {name!r} is not a free parameter "
                              f"(free: {', '.join(free) or 'none'})")
    out = []
    for name in free:
        if name not in bounds:
            raise EffectError(f"candidate {effect!r}: free parameter {name!r} has no fit range in bounds")
        lo, hi = bounds[name]
        spec = params[name]
        if not (spec.lower <= lo < hi <= spec.upper):
            raise EffectError(f"candidate {effect!r}: fit range of {name} ({lo}, {hi}) must lie within "
                              f"the effect's bounds [{spec.lower}, {spec.upper}]")
        given = (start or {}).get(name)
        s = None if given is None else float(given)
        out.append(FitParameter(effect, name, _clip(spec.default if s is None else s, lo, hi), True, lo, hi, s,
                                name in per_test))
    out += [FitParameter.held(effect, name, v) for name, v in fixed.items() if name not in free]
    return out
