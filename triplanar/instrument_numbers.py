"""The instruments' given numbers open to question: the logger's time base, the trigger's zero, and the gain, zero and
drift of each channel, as the user's calibration gives them.

A model takes its instruments as calibrated: the load cell reads the true force, the rangefinders the true
displacement, the logger the true time. Each of those numbers is a parameter of a library instrument effect
(:mod:`triplanar.effects`, ``acts_on = "instrument"``), whose identity value (the effect's neutral value: a gain of 1,
a zero of 0, a clock rate of 1) is the calibration as given. :data:`INSTRUMENT_NUMBERS` names each one so that it can
be freed like a number of the specimen (``triplanar fit --free time_base_rate``; the audit of given numbers in
``diagnose``, :mod:`triplanar.workbench.given`); it adds no physics of its own: freeing one is fitting that effect's
parameter from its identity value, and its physical range, unit and meaning are the effect's
(:class:`~triplanar.effects.Parameter`). Its default range, the calibration's tolerance, is the parameter's plausible
fit range (``Parameter.fit``: a load cell +-20 %, a rangefinder +-30 %, a zero +-5 mm, a drift +-10 mm/s, a trigger
+-50 ms, a clock +-20 %): wide, because a calibration certificate's own tolerance is no guard against the setting
typed wrong into the logger, which is how these numbers go wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .effects import REGISTRY, EffectError, Parameter


@dataclass(frozen=True)
class InstrumentNumber:
    """One freeable number of the instruments: the effect parameter that holds it."""

    name: str
    effect: str
    param: str

    @property
    def parameter(self) -> Parameter:
        return REGISTRY[self.effect].parameters[self.param]

    @property
    def given(self) -> float:
        """The calibration as given: the effect's identity (neutral) value."""
        return self.parameter.neutral_value

    def calibration_range(self) -> tuple[float, float]:
        """The default range a freed number moves over (module doc): the parameter's plausible fit range."""
        return self.parameter.fit_range(self.given)

    def refusal(self, value: float) -> str | None:
        """Why this number cannot take ``value`` (``None``: it can): outside the effect parameter's physical range."""
        p = self.parameter
        if p.lower <= value <= p.upper:
            return None
        unit = "" if p.unit == "-" else f" {p.unit}"
        return (f"{self.name} = {value:g}{unit} is outside the physical range [{p.lower:g}, {p.upper:g}] "
                f"({self.effect}.{self.param}: {p.doc})")


#: Every freeable number of the instruments by name (the order the help lists them), each an instrument effect's
#: parameter: the one place that defines it.
INSTRUMENT_NUMBERS: dict[str, InstrumentNumber] = {n.name: n for n in (
    InstrumentNumber("time_base_rate", "time_base", "rate"),
    InstrumentNumber("time_offset_s", "time_offset", "dt_s"),
    InstrumentNumber("load_cell_gain", "load_cell_gain", "gain"),
    *(InstrumentNumber(f"rangefinder_gain_{a}", "rangefinder_gain", f"gain_{a}") for a in ("x1", "x3")),
    *(InstrumentNumber(f"rangefinder_offset_{a}_m", "rangefinder_offset", f"offset_{a}_m") for a in ("x1", "x3")),
    *(InstrumentNumber(f"rangefinder_drift_{a}_m_s", "rangefinder_drift", f"drift_{a}_m_s") for a in ("x1", "x3")))}


def number_of(effect: str, param: str) -> str | None:
    """The instrument number held by ``effect.param`` (``None``: not one)."""
    return next((n.name for n in INSTRUMENT_NUMBERS.values() if (n.effect, n.param) == (effect, param)), None)


def check_instrument_range(name: str, low: float, high: float) -> None:
    """Refuse (EffectError naming the number) a range the instrument number ``name`` cannot take: not two finite
    numbers, an end outside the physical range, or a range without the calibration's value (a fit starts there)."""
    number = INSTRUMENT_NUMBERS[name]
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise EffectError(f"{name}: range {low:g}:{high:g} must be two finite numbers, low < high")
    for end in (low, high):
        problem = number.refusal(end)
        if problem:
            raise EffectError(problem)
    if not low <= number.given <= high:
        raise EffectError(f"{name}: the range {low:g}:{high:g} does not hold the calibration's value "
                          f"{number.given:g} (a fit starts there)")
