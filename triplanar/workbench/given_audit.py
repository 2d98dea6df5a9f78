"""The values of diagnose's audit of the given numbers (:func:`~triplanar.workbench.given.audit_given`): each
number's :class:`Signature` on the data and its :class:`GivenAudit`, with the measurement outside the shear test
that decides it. Apart from the audit's code so that the verdict holding them does not import the audit."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..instrument_numbers import INSTRUMENT_NUMBERS

if TYPE_CHECKING:
    from .candidate_result import CandidateResult


#: The measurement outside the shear test that decides a given number (the report names it).
DECIDING_MEASUREMENT = {
    "mass_kg": "weigh the block (or calibrate the load cell with a reference mass)",
    "com": "locate the mass centre (balance the block on a knife edge along each axis)",
    "cp": "measure the contact point's position on the block",
    "load_point": "measure where the tip touches the aft face",
    "inertia": "measure the block's inertia (a trifilar pendulum)",
}
#: ...and for an instrument effect, in a group of look-alikes (a given number's, or the named effects'): the
#: measurement outside the shear test that tells whether that instrument is off.
EFFECT_MEASUREMENT = {
    "load_cell_gain": "calibrate the load cell with a reference mass",
    "rangefinder_gain": "calibrate the rangefinders against a gauge block",
    "rangefinder_offset": "read the rangefinders' zero with the block against a reference stop",
    "rangefinder_drift": "log the rangefinders with the block at rest for as long as a test",
    "time_offset": "record the trigger and the actuator's start on one clock",
    "time_base": "time a known interval with the logger (its sampling rate against a reference clock)",
}


def effect_measurements(members: Sequence[str]) -> list[str]:
    """The measurements outside the shear test that decide among ``members`` (report labels: an effect's name, a
    refit marked after it): one per instrument effect among them, in their order."""
    return [EFFECT_MEASUREMENT[m.split()[0]] for m in members if m.split()[0] in EFFECT_MEASUREMENT]


def deciding_measurement(name: str) -> str:
    """What decides the given number ``name`` (the specimen's or an instrument's) outside the shear test."""
    if name in INSTRUMENT_NUMBERS:
        return EFFECT_MEASUREMENT[INSTRUMENT_NUMBERS[name].effect]
    return next(v for k, v in DECIDING_MEASUREMENT.items() if name.startswith(k))


@dataclass(frozen=True)
class Signature:
    """How the traces move with one number or effect parameter, linearised at the model as given (``column``: the
    change of the fit's residual vector per unit of the parameter, natural units) and what it can do about the
    discrepancy: ``share`` of the squared discrepancy a least-squares step removes within the parameter's range,
    ``estimate`` where that step lands (the parameter's value)."""

    label: str           # a given number's name, or ``effect.param``
    given: float
    column: np.ndarray | None = field(repr=False)   # (not kept in the Evidence: ``None`` there)
    share: float
    estimate: float


@dataclass(frozen=True)
class GivenAudit:
    """One given number in a diagnosis, the specimen's or an instrument's (:func:`audit_given`): its screen, its full cross-validated fit (``None`` when
    the screen left it out) and the entries whose signature on these data is the same within the noise (``group``)."""

    name: str
    screen: Signature
    fitted: CandidateResult | None = None
    group: tuple[str, ...] = ()

    @property
    def parameter(self) -> str:
        """The fitted parameter that holds this number (an instrument's: its effect's parameter)."""
        return INSTRUMENT_NUMBERS[self.name].param if self.name in INSTRUMENT_NUMBERS else self.name

    @property
    def deciding(self) -> str:
        """The measurement outside the shear test that decides this number."""
        return deciding_measurement(self.name)

    def deciding_with(self, twins: Sequence[str]) -> str:
        """What decides between this number and its look-alikes ``twins`` (the mass's weighing also calibrates the
        load cell: one measurement decides both)."""
        if self.name == "mass_kg" and set(twins) <= {"load_cell_gain"}:
            return self.deciding
        others = [EFFECT_MEASUREMENT.get(t) or f"a shear test that separates {t}" for t in twins]
        return f"{self.deciding}, or {', '.join(others)}"

    def as_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "given": self.screen.given, "screen_share": self.screen.share,
                               "screen_estimate": self.screen.estimate, "group": list(self.group),
                               "deciding_measurement": self.deciding}
        if self.fitted is not None:
            p = self.fitted.parameters[self.parameter]
            out.update(fitted=p.value, ci95=None if p.ci95 is None else list(p.ci95), status=p.status,
                       cv_error_mm=self.fitted.cv_error_mm, improvement=self.fitted.improvement,
                       plausible=self.fitted.plausible)
        return out
