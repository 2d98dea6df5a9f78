"""The specimen's given numbers as candidates: ``fit --free NAME`` and the audit in ``diagnose``.

A freed number is a parameter of the ``specimen`` effect (:mod:`triplanar.specimen_numbers`), so it is fitted by the
same machinery that refits a given effect's parameter (:class:`~triplanar.workbench.fit.EffectFit`, its intervals
and profiles): :func:`specimen_candidate` is its recipe, over the drawing's tolerance unless a range is given.
"""

from __future__ import annotations

from typing import Mapping

from ..effects import EffectError
from ..specimen import Foundation, Specimen, reference
from ..specimen_numbers import NUMBERS, check_range, given_values
from .candidates import Candidate

__all__ = ["parse_free", "specimen_candidate"]


def parse_free(items: list[str]) -> dict[str, tuple[float, float] | None]:
    """``--free NAME[=LOW:HIGH]`` (repeatable, SI units) as ``{name: (low, high) or None}``; names checked later."""
    out: dict[str, tuple[float, float] | None] = {}
    for item in items:
        name, eq, rng = (part.strip() for part in item.partition("="))
        if name in out:
            raise EffectError(f"--free {name}: given twice")
        if not eq:
            out[name] = None
            continue
        low, colon, high = rng.partition(":")
        try:
            if not colon:
                raise ValueError
            out[name] = (float(low), float(high))
        except ValueError:
            raise EffectError(f"--free {item!r}: expected NAME or NAME=LOW:HIGH (SI units), e.g. mass_kg=5.0:6.0") \
                from None
    return out


def specimen_candidate(free: Mapping[str, tuple[float, float] | None], specimen: Specimen | None = None,
                       foundation: Foundation | None = None) -> Candidate:
    """The recipe that frees the named numbers of ``specimen`` (default: the reference) from their given values,
    each over its range (``None``: the drawing's tolerance, :data:`triplanar.specimen_numbers.NUMBERS`). A name no
    specimen has, or a range the specimen cannot take, is refused naming the number (nothing is fitted)."""
    if not free:
        raise EffectError(f"nothing to free; freeable numbers: {', '.join(NUMBERS)}")
    if specimen is None or foundation is None:
        specimen, foundation = reference()
    for name in free:
        if name not in NUMBERS:
            check_range(name, 0.0, 1.0, specimen, foundation)      # refuses, listing the freeable numbers
    given = given_values(specimen)
    bounds = {}
    for name, rng in free.items():
        low, high = rng if rng is not None else NUMBERS[name].drawing_range(given[name])
        check_range(name, low, high, specimen, foundation)
        if not low <= given[name] <= high:
            raise EffectError(f"{name}: the range {low:g}:{high:g} does not hold the given value {given[name]:g} "
                              f"{NUMBERS[name].unit} (a fit starts there)")
        bounds[name] = (low, high)
    return Candidate("specimen", tuple(bounds), bounds, {k: given[k] for k in bounds})
