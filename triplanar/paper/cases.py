"""The paper's cases as lists of simulations (Galic, Glaser & Goodman 2008, section 4).

* A, B, C (sections 4.1-4.3, Figs. 11-13): the reference block at each load of the laboratory dataset,
  with end friction (A), without (B), and pushed hydrostatically (C), cut off at 8 cm of CP1 travel.
* D (section 4.4, Fig. 14): size x0.5 and x2 at the same 5.4 kg (inertia x c^2), at 26.7, 40, 53.4 N;
  travel x c.
* E (section 4.5, Fig. 15): mass x0.5 and x2 at the same size (inertia x d), shear force x d: the paper
  quotes 13.3, 20, 26.7 N and 53.4, 80.1, 106.8 N, rounded; here exactly d x (26.7, 40, 53.4) N.
* F (sections 4.6, 5.5, Fig. 16): scale 0.5, 1, 2 at equal density (mass x c^3, inertia x c^5), shear
  force half the block weight; travel x c.

D, E and F are each run with end friction (as case A) and without (as case B).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

from ..effects import Effect
from ..model import Model, paper_model
from ..result import SimulationResult
from ..simulate import simulate
from ..specimen import Foundation, Specimen, scale_mass, scale_size, scale_uniform

TRAVEL_M = 0.08                       # the paper's Delta q1 = 8 cm
SCALED_LOADS_N = (26.7, 40.0, 53.4)   # Fig. 14's columns; Fig. 15's are these x d
SCALE_FACTORS = {"D": (0.5, 2.0), "E": (0.5, 2.0), "F": (0.5, 1.0, 2.0)}
CASE_TITLES = {
    "A": "Case A: model with end friction (grey) vs laboratory (black)",
    "B": "Case B: model without end friction (grey) vs laboratory (black)",
    "C": "Case C: hydrostatic load, frictionless and body-fixed (grey) vs laboratory (black)",
    "D": "Case D: size x0.5 (top) and x2 (bottom), same mass; with end friction black, without grey",
    "E": "Case E: mass x0.5 (top) and x2 (bottom), same size; with end friction black, without grey",
    "F": "Case F: scale 0.5, 1, 2 at equal density, shear = weight/2; with end friction black, without grey",
}
_SCALERS: dict[str, Callable[[Specimen, float], Specimen]] = {"D": scale_size, "E": scale_mass, "F": scale_uniform}


@dataclass(frozen=True)
class Run:
    """One simulation: physics ``case`` (A, B or C) of a specimen scaled as paper case ``family``."""

    family: str            # "A", "B", "C" (reference block) or "D", "E", "F" (scaled)
    case: str              # "A" (end friction), "B" (none), "C" (hydrostatic)
    force_N: float
    factor: float = 1.0    # c (D, F) or d (E); 1 for A-C
    travel_m: float = TRAVEL_M
    column: int = 0        # panel column in the family's figure
    row: int = 0           # panel row

    @property
    def length_scale(self) -> float:
        """Factor to divide positions by to compare with the reference size."""
        return self.factor if self.family in ("D", "F") else 1.0

    @property
    def key(self) -> str:
        return f"{self.family}/{self.case}/x{self.factor:g}/{self.force_N:g}N"


def reference_runs(loads: Iterable[float]) -> list[Run]:
    """Cases A, B, C at each load (Figs. 11-13)."""
    return [Run(case, case, float(f), column=i) for case in "ABC" for i, f in enumerate(sorted(loads))]


def scaled_runs(specimen: Specimen) -> list[Run]:
    """Cases D, E, F, each with (A) and without (B) end friction (Figs. 14-16)."""
    runs: list[Run] = []
    for family in "DE":
        for row, factor in enumerate(SCALE_FACTORS[family]):
            for col, base in enumerate(SCALED_LOADS_N):
                force = base if family == "D" else base * factor
                travel = TRAVEL_M * factor if family == "D" else TRAVEL_M
                runs += [Run(family, case, force, factor, travel, col, row) for case in "AB"]
    for col, factor in enumerate(SCALE_FACTORS["F"]):
        force = scale_uniform(specimen, factor).weight_N / 2
        runs += [Run("F", case, force, factor, TRAVEL_M * factor, col, 0) for case in "AB"]
    return runs


@dataclass
class Simulator:
    """Runs :class:`Run` s on one specimen/foundation with optional extra effects (every case)."""

    specimen: Specimen
    foundation: Foundation
    effects: Sequence[Effect] = ()
    results: dict[str, SimulationResult] = field(default_factory=dict)

    def specimen_for(self, run: Run) -> Specimen:
        return _SCALERS[run.family](self.specimen, run.factor) if run.family in _SCALERS else self.specimen

    def model(self, run: Run) -> Model:
        return paper_model(run.case, run.force_N, specimen=self.specimen_for(run), foundation=self.foundation,
                           effects=self.effects)

    def __call__(self, run: Run) -> SimulationResult:
        """The run's simulation to its travel (cached)."""
        if run.key not in self.results:
            self.results[run.key] = simulate(self.model(run), travel_m=run.travel_m)
        return self.results[run.key]

    def simulate_run(self, run: Run) -> SimulationResult:
        """The run's simulation to its travel, not cached: a task for an executor (the caller caches)."""
        return simulate(self.model(run), travel_m=run.travel_m)

    def stopped_at(self, run: Run, travel_m: float) -> SimulationResult:
        """The run stopped at ``travel_m`` (not cached): its last row is exactly at that travel."""
        return simulate(self.model(run), travel_m=travel_m)
