"""One object per fitted parameter: a recipe edited parameter by parameter, its checks, and EffectFit's views."""

from __future__ import annotations

import math

import numpy as np
import pytest

from triplanar.effects import REGISTRY, EffectError
from triplanar.workbench import EffectFit, ModelSpec
from triplanar.workbench.candidates import Candidate, default_candidate
from triplanar.workbench.fit import fitted_parameters
from triplanar.workbench.fitbase import FitOutcome
from triplanar.workbench.parameters import FitParameter


def test_every_effects_recipe_round_trips_through_its_parameters() -> None:
    for name in REGISTRY:
        cand = default_candidate(name)
        params = cand.parameters()
        assert list(params) == list(REGISTRY[name].parameters)
        assert {k for k, p in params.items() if p.vary} == set(cand.free)
        assert Candidate.from_parameters(params.values()) == cand


def test_fixing_and_freeing_a_parameter_changes_the_recipe() -> None:
    params = default_candidate("end_friction").parameters()
    held = params["phi_deg"].fixed(5.0)
    assert (held.vary, held.value, held.status) == (False, 5.0, "fixed")
    cand = Candidate.from_parameters([held])
    assert cand.free == () and cand.fixed == {"phi_deg": 5.0} and cand.values({}) == {"phi_deg": 5.0}
    free = held.freed(2.0, 12.0)
    assert (free.vary, free.bounds, free.start, free.status) == (True, (2.0, 12.0), 5.0, "unfitted")
    cand = Candidate.from_parameters([free])
    assert cand.free == ("phi_deg",) and cand.bounds["phi_deg"] == (2.0, 12.0) and cand.start_values() == {
        "phi_deg": 5.0}
    # freed without a range: the effect's own plausible range around the start
    spec = REGISTRY["end_friction"].parameters["phi_deg"]
    assert held.freed().bounds == spec.fit_range(5.0)
    # a parameter of a two-parameter effect held: the other stays free, without a grid scan of two
    tilt = default_candidate("plane_tilt").parameters()
    first = next(k for k, p in tilt.items() if p.vary)
    tilt[first] = tilt[first].fixed()
    cand = Candidate.from_parameters(tilt.values())
    assert first not in cand.free and first in cand.fixed


def test_bounds_and_values_outside_the_effect_are_refused_naming_the_parameter() -> None:
    phi = default_candidate("end_friction").parameters()["phi_deg"]
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg: fit range \(-5\.0, 10\.0\)"):
        phi.freed(-5.0, 10.0)
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg: fit range \(10\.0, 5\.0\)"):
        phi.freed(10.0, 5.0)
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg: 90\.0 is outside"):
        phi.fixed(90.0)
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg: value 20\.0 is outside its fit range"):
        FitParameter("end_friction", "phi_deg", 20.0, True, 0.0, 10.0)
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg: min = nan is not a number"):
        FitParameter("end_friction", "phi_deg", 1.0, True, math.nan, 10.0)
    assert FitParameter("end_friction", "phi_deg", np.float32(1.0), True, np.float64(0.0), 10).value == 1.0
    with pytest.raises(EffectError, match="has no parameter 'phi'"):
        FitParameter("end_friction", "phi", 1.0)
    with pytest.raises(EffectError, match="unknown effect"):
        FitParameter("no_such_effect", "x", 1.0)
    with pytest.raises(EffectError, match="one effect's parameters"):
        Candidate.from_parameters([phi, default_candidate("tip_offset").parameters()["offset_m"]])
    with pytest.raises(EffectError, match=r"end_friction\.phi_deg given twice"):
        Candidate.from_parameters([phi, phi])


def test_a_fit_result_lands_on_the_parameter_objects() -> None:
    cand = default_candidate("end_friction")
    outcome = FitOutcome("fit", ("end_friction",), {"end_friction": {"phi_deg": 29.9}},
                         {"end_friction": {"phi_deg": 0.4}}, ("end_friction.phi_deg",), 1.0, {}, {}, 3, 0.0, "")
    phi = fitted_parameters(cand, outcome, cand.start_values(), 12, 0.5, 1.0)["phi_deg"]
    assert (phi.value, phi.stderr, phi.status, phi.at_bound, phi.start) == (29.9, 0.4, "at_bound", True, 0.0)
    assert phi.ci95 is not None and phi.ci95[0] < 29.9 <= phi.ci95[1]
    moved = FitOutcome("fit", ("end_friction",), {"end_friction": {"phi_deg": 0.0}},
                       {"end_friction": {"phi_deg": 0.4}}, (), 1.0, {}, {}, 3, 0.0, "")
    still = fitted_parameters(cand, moved, cand.start_values(), 12, 0.5, 1.0)["phi_deg"]
    assert (still.status, still.ci95, still.at_bound) == ("not_moved", None, False)
    assert math.isfinite(still.stderr)
    assert still.to_json() == {"value": 0.0, "vary": True, "min": 0.0, "max": 30.0, "start": 0.0, "per_test": False,
                               "stderr": 0.4, "ci95": None, "status": "not_moved", "at_bound": False}


def test_a_per_test_parameter_carries_each_tests_value() -> None:
    cand = default_candidate("tip_offset").with_per_test(["offset_m"])
    outcome = FitOutcome("fit", ("tip_offset",), {"tip_offset": {}}, {}, (), 1.0, {}, {}, 3, 0.0, "",
                         per_test={"tip_offset": {"offset_m": {"t1": -0.004, "t2": 0.003}}})
    offset = fitted_parameters(cand, outcome, cand.start_values(), 2, 0.5, 1.0)["offset_m"]
    assert (offset.per_test, offset.status, offset.ci95) == (True, "per_test", None)
    assert offset.per_test_values == {"t1": -0.004, "t2": 0.003}
    assert offset.fixed().per_test_values is None


def test_effect_fit_takes_the_base_model_in_fit_and_refuses_it_in_the_constructor() -> None:
    with pytest.raises(TypeError, match=r"fit\(tests, base\)"):
        EffectFit(["end_friction"], ModelSpec())
    with pytest.raises(TypeError, match=r"fit\(tests, base\)"):
        EffectFit(["end_friction"], base=ModelSpec())


def test_a_candidate_holds_its_recipe_as_fit_parameters() -> None:
    cand = Candidate("plane_tilt", ("dip1_deg", "dip3_deg"), {"dip1_deg": (-1.0, 1.0), "dip3_deg": (-2.0, 2.0)},
                     start={"dip3_deg": 2.5}, fixed={"dip2_deg": 0.5})
    dip1, dip3, dip2 = cand.recipe
    assert all(isinstance(p, FitParameter) for p in cand.recipe)
    assert (dip1.vary, dip1.bounds, dip1.start) == (True, (-1.0, 1.0), None)
    assert (dip3.value, dip3.start) == (2.0, 2.5)                 # the start given, clipped into its range
    assert (dip2.vary, dip2.value) == (False, 0.5)
    assert cand.free == ("dip1_deg", "dip3_deg") and cand.fixed == {"dip2_deg": 0.5} and cand.start == {"dip3_deg": 2.5}
    assert Candidate("plane_tilt", recipe=cand.recipe) == cand
    moved = cand.with_parameters([dip1.fixed(0.25)])
    assert moved.free == ("dip3_deg",) and moved.fixed == {"dip1_deg": 0.25, "dip2_deg": 0.5}
    with pytest.raises(TypeError, match="not both"):
        Candidate("plane_tilt", ("dip1_deg",), {"dip1_deg": (-1.0, 1.0)}, recipe=cand.recipe)
    with pytest.raises(EffectError, match="no fit range"):
        Candidate("plane_tilt", ("dip1_deg",), {})
    with pytest.raises(EffectError, match="given twice"):
        Candidate("plane_tilt", recipe=[dip1, dip1])
    with pytest.raises(EffectError, match="start 5.0 is outside"):
        Candidate("plane_tilt", ("dip3_deg",), {"dip3_deg": (-2.0, 2.0)}, start={"dip3_deg": 5.0})


def test_grid_and_snap_live_on_the_parameter_they_scan() -> None:
    rise = default_candidate("actuator_rise")
    (tau,) = rise.recipe
    assert tau.grid == (0.0, 0.01, 0.03, 0.08, 0.2) and tau.snap == 0.002     # the effect's own, on its parameter
    assert rise.grid == tau.grid and rise.snap == {"tau_s": 0.002}            # the candidate's views of them
    assert rise.grid_values() == [0.0, 0.01, 0.03, 0.08, 0.2]
    assert rise.values({"tau_s": tau.value + 0.001}) == {"tau_s": tau.value}   # within snap: the start
    kw = Candidate("end_friction", free=("phi_deg",), bounds={"phi_deg": (0.0, 20.0)}, grid=5, snap={"phi_deg": 0.5})
    assert kw.recipe[0].grid == 5 and kw.recipe[0].snap == 0.5 and kw.grid_values() == [0.0, 5.0, 10.0, 15.0, 20.0]
    per_test = default_candidate("tip_offset").with_per_test(["offset_m"])
    assert per_test.recipe[0].grid is None and per_test.grid == 0              # scanned per test, not once
    assert len(per_test.per_test_grid_values("offset_m")) == 9                # with the effect's grid
    own = Candidate("tip_offset", free=("offset_m",), bounds={"offset_m": (-0.01, 0.01)}, per_test=("offset_m",),
                    per_test_grid={"offset_m": 5})
    assert own.recipe[0].grid == 5 and own.per_test_grid == {"offset_m": 5}
    assert own.per_test_grid_values("offset_m") == pytest.approx([-0.01, -0.005, 0.0, 0.005, 0.01], abs=1e-15)
    with pytest.raises(EffectError, match="per_test_grid names tip_offset.offset_m, which is not a per-test"):
        Candidate("tip_offset", free=("offset_m",), bounds={"offset_m": (-0.01, 0.01)}, per_test_grid={"offset_m": 5})
    with pytest.raises(TypeError, match="not both"):
        Candidate("actuator_rise", grid=3, recipe=rise.recipe)


def test_a_joint_fit_lands_on_the_parameter_objects_of_every_effect_fitted() -> None:
    from triplanar.workbench.sweep import CandidateResult, joint_parameters
    friction = default_candidate("end_friction")
    offset = default_candidate("tip_offset").with_per_test(["offset_m"])
    outcome = FitOutcome("all", ("end_friction", "tip_offset"), {"end_friction": {"phi_deg": 8.0}, "tip_offset": {}},
                         {"end_friction": {"phi_deg": 0.2}}, (), 1.0, {}, {}, 3, 0.0, "",
                         per_test={"tip_offset": {"offset_m": {"t1": -0.004, "t2": 0.002}}})
    joint = joint_parameters((friction, offset), outcome, {"end_friction": ({"phi_deg": (7.6, 8.4)}, {"phi_deg": "fitted"})})
    phi, per = joint["end_friction"]["phi_deg"], joint["tip_offset"]["offset_m"]
    assert (phi.value, phi.stderr, phi.ci95, phi.status) == (8.0, 0.2, (7.6, 8.4), "fitted")
    assert (per.per_test, per.status, per.per_test_values) == (True, "per_test", {"t1": -0.004, "t2": 0.002})
    result = CandidateResult("tip_offset", {}, 1.0, 1.0, 0.5, True, [], joint=joint)
    assert result.all_values == {"end_friction": {"phi_deg": 8.0}, "tip_offset": {}}     # per-test: no shared value
    assert result.all_stderr == {"end_friction": {"phi_deg": 0.2}}
    assert result.all_ci95 == {"end_friction": {"phi_deg": [7.6, 8.4]}, "tip_offset": {}}
    assert result.per_test_values == {"tip_offset": {"offset_m": {"t1": -0.004, "t2": 0.002}}}
    assert result.per_test["offset_m"]["n"] == 2 and result.fixed == {}


def test_a_held_parameter_takes_the_effects_bounds_and_names_a_wrong_parameter() -> None:
    held = FitParameter.held("end_friction", "phi_deg", 5)
    spec = REGISTRY["end_friction"].parameters["phi_deg"]
    assert (held.value, held.vary, held.bounds, held.status) == (5.0, False, (spec.lower, spec.upper), "fixed")
    with pytest.raises(EffectError, match="effect 'end_friction' has no parameter 'nope'"):
        FitParameter.held("end_friction", "nope", 1.0)
