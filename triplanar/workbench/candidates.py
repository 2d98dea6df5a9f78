"""Candidate effects: which parameters of an effect a fit moves, within which plausible range, from where.

A candidate is an effect plus a fitting recipe. The built-in recipes keep the number of free parameters
small (every free parameter multiplies the cost of a fit and weakens identifiability); the choices:

================== ============================ ==================================== ==========================
effect             free (fit range)             fixed                                start
================== ============================ ==================================== ==========================
end_friction       phi_deg (0, 30) deg                                               grid of 7, then polish
rate_friction      a (-0.3, 1)                  v0_m_s = 0.05 m/s (a and v0 trade    grid of 7, then polish
                                                off over the 0.1-1 m/s of a test)
tip_offset         offset_m (-0.02, 0.02) m                                          grid of 9, then polish
actuator_rise      tau_s (0, 0.3) s             below 2 ms: 0 (one sample at 200 Hz  grid 0, 10, 30, 80, 200
                                                is 5 ms: a faster rise is not        ms, then polish
                                                resolved by the data)
contact_friction   phi1..3_deg (spec +- 8 deg)                                       the specimen's angles
plane_tilt         dip1_deg (-1, 0.5) deg,      dip directions unchanged (a change   0 (the drawing)
                   dip2, dip3_deg (-3, 3) deg   of dip direction by a few degrees
                                                moves CP2 off its plane)
================== ============================ ==================================== ==========================

FP1's dip is fitted within (-1, 0.5) deg: the effect's bound (+-1 deg) keeps the re-seated block within 5 mm
of the drawing, but a forward dip of more than 0.58 deg (toward e1) puts CP2 under FP2's extension more
than 0.1 mm at rest, where the core ends the run at t = 0 (``left_plane``): a cliff in the objective that
the fit must not straddle. FP2's and FP3's dips move no resting contact point.

The start is the effect's *neutral* value (the effect does nothing there) or a coarse grid over the range,
never the value a dataset was made with. A fitted value at the edge of its range is *implausible*: the
data pushed past what the recipe considers physical, and diagnose does not name such a candidate.

A user effect registered with :func:`triplanar.register` becomes a candidate automatically: every
parameter free over its declared bounds, starting at its default (so give the default the value at which
the effect does nothing); a one-parameter effect gets a grid of 7. Pass your own :class:`Candidate` for
anything else.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Mapping

from ..effects import REGISTRY, EffectError

BUILTIN = ("end_friction", "rate_friction", "tip_offset", "actuator_rise", "contact_friction", "plane_tilt")


@dataclass(frozen=True)
class Candidate:
    """An effect and how to fit it.

    Attributes:
        effect: registered effect name.
        free: parameters the fit moves.
        bounds: fit (plausible) range of each free parameter.
        start: start value of each free parameter (``None``: the effect's default).
        fixed: values of the other parameters (missing ones: the effect's default).
        grid: a coarse grid scan before polishing (one free parameter only): a number of evenly spaced
            points over the range, or the values themselves; 0: none.
        snap: values closer than this to the start value are set to it (a parameter whose small values are
            unresolvable, or that the core integrates badly, like a rise time of microseconds).
    """

    effect: str
    free: tuple[str, ...]
    bounds: Mapping[str, tuple[float, float]]
    start: Mapping[str, float] | None = None
    fixed: Mapping[str, float] = field(default_factory=dict)
    grid: int | tuple[float, ...] = 0
    snap: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.effect not in REGISTRY:
            raise EffectError(f"unknown effect {self.effect!r}; known effects: {', '.join(sorted(REGISTRY))}")
        params = REGISTRY[self.effect].parameters
        for name in (*self.free, *self.fixed):
            if name not in params:
                raise EffectError(f"effect {self.effect!r} has no parameter {name!r} "
                                  f"(its parameters: {', '.join(params) or 'none'})")
        for name in self.free:
            lo, hi = self.bounds[name]
            spec = params[name]
            if not (spec.lower <= lo < hi <= spec.upper):
                raise EffectError(f"candidate {self.effect!r}: fit range of {name} ({lo}, {hi}) must lie within "
                                  f"the effect's bounds [{spec.lower}, {spec.upper}]")

    def start_values(self) -> dict[str, float]:
        params = REGISTRY[self.effect].parameters
        start = dict(self.start or {})
        out = {}
        for name in self.free:
            lo, hi = self.bounds[name]
            out[name] = min(max(float(start.get(name, params[name].default)), lo), hi)
        return out

    def values(self, free_values: Mapping[str, float]) -> dict[str, float]:
        """All parameter values: fixed ones plus the given free ones (snapped, see ``snap``)."""
        start = self.start_values()
        free = {}
        for k in self.free:
            v = float(free_values[k])
            free[k] = start[k] if abs(v - start[k]) < self.snap.get(k, 0.0) else v
        return {**{k: float(v) for k, v in self.fixed.items()}, **free}

    def grid_values(self) -> list[float]:
        """The grid scan's values of the (single) free parameter, in natural units ([] for none)."""
        if not self.grid or len(self.free) != 1:
            return []
        lo, hi = self.bounds[self.free[0]]
        if isinstance(self.grid, int):
            return [lo + (hi - lo) * i / (self.grid - 1) for i in range(self.grid)] if self.grid > 1 else [lo]
        return [float(v) for v in self.grid]


def builtin_candidates(friction_deg: Iterable[float] = (17.0, 14.0, 11.0)) -> dict[str, Candidate]:
    """The built-in recipes (module doc); ``friction_deg``: the user's specimen's contact angles."""
    phis = [float(x) for x in friction_deg]
    contact = {f"phi{i}_deg": (max(0.0, p - 8.0), min(44.0, p + 8.0)) for i, p in enumerate(phis, start=1)}
    return {
        "end_friction": Candidate("end_friction", ("phi_deg",), {"phi_deg": (0.0, 30.0)}, {"phi_deg": 0.0}, grid=7),
        "rate_friction": Candidate("rate_friction", ("a",), {"a": (-0.3, 1.0)}, {"a": 0.0},
                                   fixed={"v0_m_s": 0.05}, grid=7),
        "tip_offset": Candidate("tip_offset", ("offset_m",), {"offset_m": (-0.02, 0.02)}, {"offset_m": 0.0},
                                grid=9),
        "actuator_rise": Candidate("actuator_rise", ("tau_s",), {"tau_s": (0.0, 0.3)}, {"tau_s": 0.0},
                                   grid=(0.0, 0.01, 0.03, 0.08, 0.2), snap={"tau_s": 0.002}),
        "contact_friction": Candidate("contact_friction", ("phi1_deg", "phi2_deg", "phi3_deg"), contact,
                                      {f"phi{i}_deg": p for i, p in enumerate(phis, start=1)}),
        "plane_tilt": Candidate("plane_tilt", ("dip1_deg", "dip2_deg", "dip3_deg"),
                                {"dip1_deg": (-1.0, 0.5), "dip2_deg": (-3.0, 3.0), "dip3_deg": (-3.0, 3.0)},
                                {f"dip{i}_deg": 0.0 for i in (1, 2, 3)}),
    }


def default_candidate(name: str) -> Candidate:
    """A recipe for any registered effect: all parameters free over their bounds, from their defaults."""
    if name not in REGISTRY:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(sorted(REGISTRY))}")
    params = REGISTRY[name].parameters
    return Candidate(name, tuple(params), {k: (p.lower, p.upper) for k, p in params.items()},
                     {k: p.default for k, p in params.items()}, grid=7 if len(params) == 1 else 0)


def candidate_library(names: Iterable[str] | None = None, exclude: Iterable[str] = (),
                      friction_deg: Iterable[float] = (17.0, 14.0, 11.0)) -> list[Candidate]:
    """Candidates for ``names`` (default: every registered effect), minus ``exclude``."""
    builtin = builtin_candidates(friction_deg)
    names = list(REGISTRY) if names is None else list(names)
    skip = set(exclude)
    return [builtin[n] if n in builtin else default_candidate(n) for n in names if n not in skip]


def resolve(candidates: Iterable[Candidate | str] | None, exclude: Iterable[str] = (),
            friction_deg: Iterable[float] = (17.0, 14.0, 11.0)) -> list[Candidate]:
    """Normalise a user's candidate list (names or :class:`Candidate`), dropping excluded names."""
    if candidates is None:
        return candidate_library(None, exclude, friction_deg)
    skip = set(exclude)
    out: list[Candidate] = []
    candidates_seen: set[str] = set()
    for c in candidates:
        cand = c if isinstance(c, Candidate) else candidate_library([c], (), friction_deg)[0]
        if cand in out or (isinstance(c, str) and c in candidates_seen):
            raise ValueError(f"candidate {cand.effect!r} given twice")
        if isinstance(c, str):
            candidates_seen.add(c)
        if cand.effect not in skip:
            out.append(cand)
    return out
