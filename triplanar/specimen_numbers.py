"""The specimen's given numbers open to question: the ``specimen`` effect changes named numbers of the specimen file.

A laboratory's model is wrong as often in the numbers it was given (a drawing, a weighing) as in the physics it
lacks. The effect ``specimen`` holds one parameter per number of the specimen file (``docs/specimen-format.md``)
that a fit may free by name (``triplanar fit --free NAME``, :func:`triplanar.workbench.given.specimen_candidate`);
a parameter left unset (NaN, its default) leaves the file's number as given, so ``specimen:mass_kg=5.7`` is the
specimen file with ``mass_kg = 5.7`` written in it and nothing else changed. Each number keeps the file's meaning:
the mass centre stays relative to CP1 in the body frame (eq. 24), the load point ``P_CL = P1 + A g2 - B g3``
(eq. 27) relative to CP1, the inertia's diagonal in the body axes. One exception: ``mass_kg`` scales the inertia
with it (the drawing's shape with more or less material, as the paper's case E, ``scale_mass``), so that a block
``k`` times heavier under a force ``F`` moves exactly as the drawn block under ``F / k``; an inertia number freed
beside it is set after that scaling.

A contact point's horizontal coordinates (``cpN_x1_m``, ``cpN_x3_m``) can be freed; its height is not a free
number: a contact point lies on its foundation plane (paper section 3), so the height follows the plane
(:meth:`~triplanar.specimen.Plane.height`). The friction angles are refitted by the effects ``contact_friction``
and ``end_friction`` and are not repeated here.

The effect is registered (``--effect specimen:NAME=VALUE`` works on every command) but is not a candidate of the
effect library (:data:`triplanar.effects.BUILTIN`, the workbench's default candidates): ``diagnose`` audits the
given numbers separately (:mod:`triplanar.workbench.given`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from .effects import Effect, EffectError, Parameter, register
from .specimen import Foundation, Specimen, SpecimenError

if TYPE_CHECKING:
    from .model import Model

#: The drawing's tolerances, the default range a freed number may move over (``given +- tolerance``; ``relative``:
#: a fraction of the given value). Reasons: a block's mass computed from its drawing (nominal volume x handbook
#: density) misses pockets, inserts, the alloy's density spread and fixtures by a few per cent, and the issue that
#: motivated this found a block 6 % heavier than its drawing: +-10 %. A machined contact pad, a mass centre
#: computed from a drawing of a pocketed block and the tip's contact on the aft face set by hand are each located
#: within a few millimetres: +-5 mm. The inertia follows the mass (+-10 %) and the squared dimensions: +-15 %.
LENGTH_TOLERANCE_M = 0.005
MASS_TOLERANCE = 0.10
INERTIA_TOLERANCE = 0.15


@dataclass(frozen=True)
class GivenNumber:
    """One freeable number: how to read it from a specimen, its physical range (SI) and its drawing tolerance."""

    name: str
    unit: str
    doc: str
    lower: float                 # physical range: a value outside cannot describe a block (or the file's check)
    upper: float
    tolerance: float
    relative: bool
    read: Callable[[Specimen], float]

    def drawing_range(self, given: float) -> tuple[float, float]:
        """``given +- tolerance`` (relative: a fraction of ``given``), within the physical range."""
        half = abs(given) * self.tolerance if self.relative else self.tolerance
        return max(self.lower, given - half), min(self.upper, given + half)

    @property
    def tolerance_text(self) -> str:
        return f"+-{self.tolerance:.0%}" if self.relative else f"+-{self.tolerance * 1e3:g} mm"


def _numbers() -> dict[str, GivenNumber]:
    out = {"mass_kg": GivenNumber("mass_kg", "kg", "the block's mass", 1e-6, 1e4, MASS_TOLERANCE, True,
                                  lambda s: float(s.mass_kg))}
    for i in range(3):
        out[f"com_g{i + 1}_m"] = GivenNumber(
            f"com_g{i + 1}_m", "m", f"mass centre relative to CP1 along body axis g{i + 1} (mass_centre_m[{i}])",
            -1.0, 1.0, LENGTH_TOLERANCE_M, False, lambda s, i=i: float(s.mass_centre_m[i]))
    for cp in range(3):
        for axis in (0, 2):
            name = f"cp{cp + 1}_x{axis + 1}_m"
            out[name] = GivenNumber(name, "m", f"CP{cp + 1}'s rest x{axis + 1} (contact_points_m[{cp}][{axis}]; its "
                                    f"height follows FP{cp + 1})", -1.0, 1.0, LENGTH_TOLERANCE_M, False,
                                    lambda s, cp=cp, axis=axis: float(s.contact_points_m[cp, axis]))
    out["load_point_A_m"] = GivenNumber("load_point_A_m", "m", "the tip's line of action: height A above CP1 "
                                        "along g2 (eq. 27)", -1.0, 1.0, LENGTH_TOLERANCE_M, False,
                                        lambda s: float(s.load_point_A_m))
    out["load_point_B_m"] = GivenNumber("load_point_B_m", "m", "the tip's line of action: offset B from CP1 "
                                        "along -g3 (eq. 27)", -1.0, 1.0, LENGTH_TOLERANCE_M, False,
                                        lambda s: float(s.load_point_B_m))
    for i in range(3):
        out[f"inertia_g{i + 1}_kg_m2"] = GivenNumber(
            f"inertia_g{i + 1}_kg_m2", "kg m^2", f"moment of inertia about the mass centre along g{i + 1} "
            f"(inertia_kg_m2[{i}][{i}])", 1e-9, 100.0, INERTIA_TOLERANCE, True,
            lambda s, i=i: float(s.inertia_kg_m2[i, i]))
    return out


#: Every freeable number by name, in the order the help lists them.
NUMBERS: dict[str, GivenNumber] = _numbers()


def given_values(specimen: Specimen) -> dict[str, float]:
    """Every freeable number's value as the specimen gives it."""
    return {name: n.read(specimen) for name, n in NUMBERS.items()}


def with_numbers(specimen: Specimen, foundation: Foundation, values: dict[str, float]) -> Specimen:
    """``specimen`` with the named numbers replaced (NaN: as given); a moved contact point is re-seated on its plane."""
    values = {k: float(v) for k, v in values.items() if not math.isnan(float(v))}
    if not values:
        return specimen
    cps = np.array(specimen.contact_points_m)
    com = np.array(specimen.mass_centre_m)
    inertia = np.array(specimen.inertia_kg_m2)
    changes: dict[str, object] = {}
    if "mass_kg" in values:       # the drawing's shape with more or less material: the inertia scales with the mass
        changes["mass_kg"] = values["mass_kg"]
        inertia *= values["mass_kg"] / specimen.mass_kg
    for name, v in values.items():
        if name == "mass_kg":
            continue
        elif name.startswith("com_g"):
            com[int(name[5]) - 1] = v
        elif name.startswith("cp"):
            cp, axis = int(name[2]) - 1, int(name[5]) - 1
            cps[cp, axis] = v
            cps[cp, 1] = float(foundation.planes[cp].height(cps[cp, 0], cps[cp, 2]))
        elif name.startswith("inertia_g"):
            inertia[int(name[9]) - 1, int(name[9]) - 1] = v
        else:
            changes[name] = v
    return replace(specimen, contact_points_m=cps, mass_centre_m=com, inertia_kg_m2=inertia, **changes)


def check_range(name: str, low: float, high: float, specimen: Specimen, foundation: Foundation) -> None:
    """Refuse (EffectError naming the number) a range a freed number cannot take: unknown name, a contact point's
    height, an end outside the physical range, or an end at which the specimen fails its own check."""
    if name not in NUMBERS:
        if name.startswith("cp") and name.endswith("_x2_m"):
            raise EffectError(f"{name}: a contact point's height is not free: it lies on its plane FP{name[2]} (free "
                              f"{name[:3]}_x1_m or {name[:3]}_x3_m; the height follows the plane)")
        raise EffectError(f"no specimen number {name!r}; freeable numbers: {', '.join(NUMBERS)}")
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise EffectError(f"{name}: range {low:g}:{high:g} must be two finite numbers, low < high")
    for end in (low, high):
        problem = refusal(name, end, specimen, foundation)
        if problem:
            raise EffectError(problem)


def refusal(name: str, value: float, specimen: Specimen, foundation: Foundation) -> str | None:
    """Why the freeable number ``name`` cannot take ``value`` (``None``: it can)."""
    number = NUMBERS[name]
    if not number.lower <= value <= number.upper:
        return (f"{name} = {value:g} {number.unit} is outside the physical range [{number.lower:g}, "
                f"{number.upper:g}] ({number.doc})")
    try:
        changed = with_numbers(specimen, foundation, {name: value})
        changed.validate(foundation)
    except SpecimenError as err:
        return f"{name} = {value:g} {number.unit} does not describe a physical specimen: {err}"
    if name.startswith("cp"):
        crossing = _crossing_at_rest(changed, foundation)
        if crossing:
            return f"{name} = {value:g} {number.unit} puts the block off its planes: {crossing}"
    return None


def _crossing_at_rest(specimen: Specimen, foundation: Foundation) -> str | None:
    """Why the block seated on ``foundation`` cannot rest with each contact point on its own plane (``None``: it can).
    The reference's CP2 and CP3 rest on the lines where their planes meet FP1 (paper section 3), so a pad moved a
    millimetre the wrong way lies under FP1; the specimen's own check (a static one) does not see that, the kernel's
    start does (a run ends at t = 0 with ``left_plane``), so the start is asked: a run of 0.1 mm at the paper's
    highest load."""
    from .model import paper_model
    from .outcome import Outcome
    from .simulate import simulate
    result = simulate(paper_model("B", 55.6, specimen, foundation), travel_m=1e-4, t_max_s=0.05)
    return result.message if result.status is Outcome.LEFT_PLANE and result.t[-1] == 0.0 else None


@register
class GivenSpecimen(Effect):
    """Numbers of the specimen file other than given (module doc): each parameter, when set, replaces one number."""

    name = "specimen"
    acts_on = "specimen"
    parameters = {name: Parameter(math.nan, n.lower, n.upper, n.unit, n.doc, free=False)
                  for name, n in NUMBERS.items()}

    @classmethod
    def fit_start(cls, specimen: Specimen) -> dict[str, float]:
        """The specimen's own numbers (where the effect does nothing)."""
        return given_values(specimen)

    def apply(self, model: Model) -> Model:
        return replace(model, specimen=with_numbers(model.specimen, model.foundation, self.values))
