"""The experiment that would decide between two look-alike explanations.

When diagnose cannot tell two entries apart (each within the other's uncertainty on the data at hand), their
fitted models still predict different paths somewhere. This module asks the model where: at each load level of a
grid it simulates entry A's fitted model, samples it as a test would be (uniformly at ``RATE_HZ``), and measures
entry B's fitted model against that trace with the workbench's own discrepancy (``error_mm``: paths at equal travel
and the travel lag). The ratio of that difference to the per-test scatter says where a test is most informative;
the repeats needed to separate the two at 95 % follow from it:

    n = ceil((2 z_0.95 sigma / delta)^2),  z_0.95 = 1.645,

the number of repeats for which the mean of the repeats lies on the right side of the midpoint between the two
predictions with probability 0.95 (the midpoint is delta / 2 from each; the mean scatters by sigma / sqrt(n)).
``sigma`` is the repeats' scatter of the data at hand (per test, in the units of ``error_mm``); it is not known at
loads that were not measured, so it is taken as the same there (stated in the report).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..measurement import MeasuredTest
from ..simulate import simulate
from .spec import SIM_OPTIONS, EvalTask, ModelSpec
from .fitbase import safe_evaluate
from .sweep import spec_of
from .verdict import label
from ..outcome import Outcome

if TYPE_CHECKING:
    from .verdict import Evidence

#: Samples per second of the simulated tests (the laboratory's rate).
RATE_HZ = 200.0
#: The one-sided normal quantile of the 95 % separation.
Z95 = 1.6449


def _trace(spec: ModelSpec, force_N: float, travel_m: float) -> MeasuredTest | None:
    """Entry A's prediction at ``force_N`` as a test would record it (``None`` where it does not slide)."""
    try:
        result = simulate(spec.build(force_N), travel_m=travel_m, **SIM_OPTIONS)
    except (ValueError, ArithmeticError):
        return None
    if result.status is Outcome.HELD or result.t[-1] <= 0:
        return None
    t_s = np.arange(0, int(math.floor(result.t[-1] * RATE_HZ + 1e-9)) + 1) / RATE_HZ
    if len(t_s) < 4:
        return None
    return MeasuredTest(f"predicted-{force_N:g}N", float(force_N), result.contact_points_at(t_s), t_s)


def repeats_needed(delta_mm: float, sigma_mm: float) -> int | None:
    """Repeats at one load for a 95 % separation of predictions ``delta_mm`` apart (module doc)."""
    if not (math.isfinite(delta_mm) and delta_mm > 0 and math.isfinite(sigma_mm)):
        return None
    return max(1, math.ceil((2 * Z95 * sigma_mm / delta_mm) ** 2))


def deciding_experiment(a: tuple[str, ModelSpec], b: tuple[str, ModelSpec], sigma_mm: float,
                        loads: Sequence[float], travel_m: float = 0.08) -> dict[str, Any]:
    """Where ``a``'s and ``b``'s fitted models (``(label, spec)``) differ most relative to ``sigma_mm``: per load,
    the difference (mm, ``error_mm`` of b against a's predicted trace), its ratio to the scatter, the repeats needed,
    and the travel at which the lateral difference is largest; the best load first in ``best``."""
    rows = []
    for force in sorted(set(float(f) for f in loads)):
        trace = _trace(a[1], force, travel_m)
        if trace is None:
            # one holds the block: if the other slides, one test there decides
            slides = _trace(b[1], force, travel_m) is not None
            rows.append({"load_N": force, "difference_mm": None, "ratio": None, "repeats": 1 if slides else None,
                         "travel_mm": None, "holds": a[0] if slides else None,
                         "note": f"{a[0]} holds the block, {b[0]} slides" if slides else "neither slides"})
            continue
        if _trace(b[1], force, travel_m) is None:
            rows.append({"load_N": force, "difference_mm": None, "ratio": None, "repeats": 1, "travel_mm": None,
                         "holds": b[0], "note": f"{b[0]} holds the block, {a[0]} slides"})
            continue
        found = safe_evaluate(EvalTask(b[1], force, (trace,), report=False)).discrepancies[0]
        lateral = np.nan_to_num(np.abs(found.lateral_mm)).max(axis=1)
        where = float(found.travel_m[int(np.argmax(lateral))]) * 1000 if len(lateral) else math.nan
        delta = float(found.error_mm)
        rows.append({"load_N": force, "difference_mm": delta,
                     "ratio": delta / sigma_mm if sigma_mm > 0 else None,
                     "repeats": repeats_needed(delta, sigma_mm), "travel_mm": where,
                     "note": "" if found.status is Outcome.TRAVEL else f"{b[0]}: {found.status}"})
    usable = [r for r in rows if r["difference_mm"] is not None and r["repeats"] is not None]
    split = [r for r in rows if r.get("holds")]
    # a load where one model holds and the other slides decides at once; the highest such load is the least
    # sensitive to the threshold's own scatter
    best = max(split, key=lambda r: r["load_N"]) if split else (
        max(usable, key=lambda r: r["difference_mm"]) if usable else None)
    return {"between": [a[0], b[0]], "scatter_mm": sigma_mm, "travel_m": travel_m, "rows": rows, "best": best,
            "scatter_note": "the repeats' scatter of the data at hand, assumed the same at every load"}


def describe(exp: dict[str, Any]) -> str:
    """One sentence for the report."""
    best = exp.get("best")
    a, b = exp["between"]
    if best is None:
        return f"no load of the grid separates {a} from {b} (their predictions agree, or neither slides)"
    if best.get("holds"):
        return f"to tell {a} from {b}: test at {best['load_N']:g} N, where {best['note']}: one test decides"
    return (f"to tell {a} from {b}: test at {best['load_N']:g} N, where their fitted models differ by "
            f"{best['difference_mm']:.2f} mm ({best['ratio']:.1f} x the {exp['scatter_mm']:.2f} mm scatter of one test; "
            f"largest laterally at {best['travel_mm']:.0f} mm of travel); {best['repeats']} repeat(s) there separate "
            f"them at 95 %")


def experiments_for(ev: Evidence, tests: Sequence[MeasuredTest]) -> list[dict[str, Any]]:
    """For the examined entry and each look-alike (at most two): the loads where their fitted models differ most
    relative to the scatter, and the repeats that would separate them (module doc). Evidence: the verdict's reason
    quotes each one's ``sentence``."""
    if ev.best is None or not ev.lookalikes:
        return []
    sigma = ev.repeat_scatter_mm if math.isfinite(ev.repeat_scatter_mm) else ev.expected_scatter_mm
    measured = sorted({float(t.shear_force_N) for t in tests})
    # below the lowest measured load finely (a model that holds where the other slides decides at once)
    grid = sorted(set(measured) | {round(f, 1) for f in np.linspace(measured[0], 1.3 * measured[-1], 8)}
                  | {round(k * measured[0], 1) for k in (0.8, 0.85, 0.9, 0.95)})
    longest = max((float(d.travel_m[-1]) for d in ev.baseline if len(d.travel_m)), default=0.08)
    out = []
    for other in ev.lookalikes[:2]:
        exp = deciding_experiment((label(ev.best), spec_of(ev.user_base, ev.best)),
                                  (label(other), spec_of(ev.user_base, other)), sigma, grid, max(longest, 0.01))
        exp["sentence"] = describe(exp)
        out.append(exp)
    return out
