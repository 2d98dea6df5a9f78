"""What the rigid block's test decides in the verdict beside the fits (``rules.rigid_rules_out``,
``rules.drawing_lead``): a rangefinder gain admitted only by a shared bias below the scatter is not examined where
the contact points' distances stay unchanged (a logger clock keeps them), and a contact point's number is said when
the test finds the distances off the drawing and that number removes more than every library entry, though less than
``MIN_IMPROVEMENT`` (a pad moved at the detectability limit). Evidence made by hand: no simulation."""

from __future__ import annotations

import math

from triplanar.workbench import rules
from triplanar.workbench.given_audit import GivenAudit, Signature
from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.rigidity import ALPHA, RigidityResult
from triplanar.workbench.spec import ModelSpec
from triplanar.workbench.sweep import CandidateResult
from triplanar.workbench.verdict import Evidence, VerdictKind

QUIET = {"systematic": False, "p_value_all": 1.0, "feature": None}
HIDDEN = {"systematic": True, "p_value_all": 1e-5, "feature": "mean x1 error CP1 (mm)", "mean": 0.2, "levels": 4,
          "z": 4.5}


def _rigidity(kind: str, broken: tuple[str, ...] = ()) -> RigidityResult:
    return RigidityResult(kind, 1e-100 if broken else 1.0, ALPHA, (), broken, None, 0.4, 10, f"the test says {kind}")


def _fit(effect: str, name: str, value: float, ci: tuple[float, float], improvement: float,
         baseline_mm: float) -> CandidateResult:
    cv = (1 - improvement) * baseline_mm
    p = FitParameter(effect, name, value, True, ci[0], ci[1], stderr=(ci[1] - ci[0]) / 4, ci95=ci,
                     status="fitted")
    return CandidateResult(effect, {name: p}, cv, cv, improvement, True, [],
                           held_out_mm={f"t{i}": cv for i in range(6)})


def _evidence(base: float, ranked: list[CandidateResult], bias: dict, rigidity: RigidityResult,
              numbers: tuple[GivenAudit, ...] = ()) -> Evidence:
    scatter = 0.6
    best, look = rules.examined_entry(ranked, base, scatter, bias["p_value_all"], rigidity)
    return Evidence(ModelSpec(), ModelSpec(), {}, [[30.0], [40.0]], [], base, {30.0: base}, scatter, 0.3, 0.1, 0.6,
                    0.2, ranked, {}, bias, best, look, None, {}, math.nan, QUIET if best is not None else bias,
                    given_numbers=numbers, rigidity=rigidity)


def test_a_rangefinder_gain_the_rigid_block_contradicts_is_not_examined_under_a_hidden_bias() -> None:
    """The model as given within the scatter (0.8 mm against 0.6), a shared bias at p = 1e-5: the rangefinder gain
    removes 20 %, a time offset 15 %. Where the test says the block stays rigid the gain is passed over for the time
    offset; where it says a channel misreads, the gain is examined as before."""
    base = 0.8
    ranked = [_fit("rangefinder_gain", "gain_x1", 1.05, (1.03, 1.07), 0.20, base),
              _fit("time_offset", "dt_s", -0.003, (-0.005, -0.001), 0.15, base)]
    rigid = _evidence(base, ranked, HIDDEN, _rigidity("specimen_or_load"))
    assert rigid.best is not None and rigid.best.effect == "time_offset"
    seen = _evidence(base, ranked, HIDDEN, _rigidity("instrument", ("CP1-CP3",)))
    assert seen.best is not None and seen.best.effect == "rangefinder_gain"
    # an entry that removes MIN_IMPROVEMENT stands on its own: the rigid block's finding does not pass it over
    strong = [_fit("rangefinder_gain", "gain_x1", 1.05, (1.03, 1.07), rules.MIN_IMPROVEMENT + 0.05, base)]
    assert _evidence(base, strong, HIDDEN, _rigidity("specimen_or_load")).best is not None


def _pad_audit(name: str, improvement: float, base: float) -> GivenAudit:
    fit = _fit("specimen", name, 0.0021, (0.0019, 0.0023), improvement, base)
    return GivenAudit(name, Signature(name, 0.0, None, 0.25, 0.002), fit)


def test_a_contact_point_off_the_drawing_is_said_where_the_rigid_block_points_at_it() -> None:
    """No entry explains (the best removes 5 %), the model as given 1.0 mm against a scatter of 0.6: CP2's x1 refitted
    removes 25 % (under MIN_IMPROVEMENT) and CP1's 10 %. With the test finding CP1-CP2 off the drawing, CP2's number
    (the one of the pair's points that removes most) is said, CP1's is not; with the block as drawn, neither."""
    base = 0.9
    ranked = [_fit("rangefinder_gain", "gain_x1", 1.01, (0.99, 1.03), 0.05, base)]
    numbers = (_pad_audit("cp2_x1_m", 0.25, base), _pad_audit("cp1_x1_m", 0.10, base))
    off = rules.decide(_evidence(base, ranked, QUIET, _rigidity("instrument_or_drawing", ("CP1-CP2",)), numbers))
    assert off.kind is VerdictKind.OUTSIDE_LIBRARY
    assert "your given cp2_x1_m = 0 is probably 0.0021" in off.reason, off.reason
    assert "your given cp1_x1_m" not in off.reason
    assert any(r.rule == "rigidity.instrument_or_drawing" for r in off.reasons)
    drawn = rules.decide(_evidence(base, ranked, QUIET, _rigidity("specimen_or_load"), numbers))
    assert "your given" not in drawn.reason, drawn.reason
    # a pair not holding CP2 points elsewhere: CP2's number is not the lead
    other = rules.decide(_evidence(base, ranked, QUIET, _rigidity("instrument_or_drawing", ("CP1-CP3",)),
                                   numbers[:1]))
    assert "your given" not in other.reason, other.reason


def test_forward_selection_starts_from_the_gain_the_rigid_block_sees_even_at_its_bound_alone() -> None:
    """The test says a channel misreads along the travel; the load-cell gain is examined (it removes 40 %) and the
    rangefinder gain alone ends at its bound (implausible alone: a load-cell gain partly cancels it). Forward selection
    also starts from the rangefinder gain, whose joint fit with a partner frees it again; not where the block is
    rigid."""
    base = 2.0
    gain = _fit("rangefinder_gain", "gain_x1", 1.3, (1.28, 1.3), 0.20, base)
    gain.plausible, gain.at_bound = False, ["gain_x1"]
    ranked = [_fit("load_cell_gain", "gain", 1.08, (1.06, 1.10), 0.40, base), gain]
    seen = _evidence(base, ranked, QUIET, _rigidity("instrument", ("CP1-CP3",)))
    assert seen.best is not None and seen.best.effect == "load_cell_gain"
    assert rules.rigidity_start(seen) is gain
    assert rules.rigidity_start(_evidence(base, ranked, QUIET, _rigidity("specimen_or_load"))) is None
