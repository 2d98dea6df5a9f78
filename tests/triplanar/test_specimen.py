"""Specimen/foundation files and validation; effects' interface; the result's CSV and resampling."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dataclasses import replace

from triplanar import (EFFECTS, EffectError, Foundation, Plane, SpecimenError, load_toml, make_effect, paper_model,
                       read_measurements, reference, simulate)
from triplanar.specimen import to_toml

SPECIMEN, FOUNDATION = reference()


def test_reference_values_are_the_design_notes() -> None:
    assert SPECIMEN.mass_kg == 5.4
    assert SPECIMEN.friction_deg == (17.0, 14.0, 11.0) and SPECIMEN.tip_friction_deg == 8.0
    assert np.allclose(SPECIMEN.mass_centre_world, [-0.025, 0.022, 0.12])
    assert np.allclose(SPECIMEN.load_point_world, [-0.14, 0.015, 0.12])
    assert np.allclose(SPECIMEN.body_axes, np.eye(3))
    assert np.allclose(FOUNDATION.normals[2], [-0.2962, 0.9397, 0.1710], atol=1e-4)


def test_toml_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(to_toml(SPECIMEN, FOUNDATION))
    specimen, foundation = load_toml(path)
    assert np.array_equal(specimen.inertia_kg_m2, SPECIMEN.inertia_kg_m2)
    assert specimen.friction_deg == SPECIMEN.friction_deg and foundation == FOUNDATION


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("change, field", [
    (("mass_kg = 5.4", "mass_kg = -1.0"), "mass_kg"),
    (("mass_kg = 5.4", "mass_kg = 0.0"), "mass_kg"),
    (("[[0.04139, 0.0, 0.0]", "[[0.04139, 0.001, 0.0]"), "inertia_kg_m2"),                  # not symmetric
    (("[0.0, 0.0, 0.01101]]", "[0.0, 0.0, -0.01101]]"), "inertia_kg_m2"),                  # not positive
    (("[0.0, 0.0, 0.01101]]", "[0.0, 0.0, 0.2]]"), "inertia_kg_m2"),                       # triangle inequality
    (("[0.0, 0.0, 0.24], [0.0, 0.0, 0.0]]", "[0.0, 0.01, 0.24], [0.0, 0.0, 0.0]]"), "contact_points_m[1]"),
    (("mass_centre_m = [0.115", "mass_centre_m = [0.215"), "mass_centre_m"),              # outside the triangle
    (("friction_deg = [17.0", "friction_deg = [45.0"), "friction_deg[0]"),
    (("friction_deg = [17.0", "friction_deg = [-1.0"), "friction_deg[0]"),
    (("tip_friction_deg = 8.0", "tip_friction_deg = 50.0"), "tip_friction_deg"),
    (("mass_kg = 5.4", "mass_kg = nan"), "mass_kg"),
    (("load_point_A_m = 0.015", "load_point_A_m = inf"), "load_point_A_m"),
    (("dip_deg = 9.5", "dip_deg = 95.0"), "foundation.planes[1].dip_deg"),
    (("mass_kg = 5.4", "mass_kg = 'heavy'"), "specimen.mass_kg"),
    (("mass_kg = 5.4\n", ""), "specimen.mass_kg"),                                         # missing
    (("mass_kg = 5.4", "mass_kg = 5.4\ncolour = 'red'"), "specimen.colour"),              # unknown key
])
def test_each_validation_rule_names_its_field(tmp_path: Path, change: tuple[str, str], field: str) -> None:
    text = to_toml(SPECIMEN, FOUNDATION)
    assert change[0] in text, change[0]
    path = _write(tmp_path, text.replace(change[0], change[1], 1))
    with pytest.raises(SpecimenError) as err:
        load_toml(path)
    assert err.value.field == field
    assert str(path) in str(err.value) and field in str(err.value)


def test_bad_toml_syntax_names_the_file(tmp_path: Path) -> None:
    path = _write(tmp_path, "[specimen\nmass_kg = 1")
    with pytest.raises(SpecimenError, match="bad.toml"):
        load_toml(path)


def test_bad_simulation_arguments() -> None:
    with pytest.raises(SpecimenError, match="loading.force_N"):
        paper_model("A", float("nan"))
    with pytest.raises(SpecimenError, match="case"):
        paper_model("Z", 30.0)
    with pytest.raises(ValueError, match="method"):
        simulate(paper_model("A", 30.0), method="magic")
    with pytest.raises(ValueError, match="travel_m"):
        simulate(paper_model("A", 30.0), travel_m=-1.0)


def test_effects_interface() -> None:
    assert {"end_friction", "rate_friction", "tip_offset", "actuator_rise", "contact_friction",
            "plane_tilt"} <= set(EFFECTS)
    effect = make_effect("end_friction:phi_deg=5")
    model = paper_model("B", 30.0, effects=[effect])
    assert model.tan_phi_EF == pytest.approx(np.tan(np.radians(5.0)))
    with pytest.raises(EffectError, match="known effects: .*end_friction"):
        make_effect("no_such_effect")
    with pytest.raises(EffectError, match="has no parameter 'phi'"):
        make_effect("end_friction:phi=3")
    with pytest.raises(EffectError, match="outside"):
        make_effect("tip_offset:offset_m=1.0")
    with pytest.raises(EffectError, match="not a number"):
        make_effect("tip_offset:offset_m=abc")


def test_end_friction_effect_turns_case_b_into_case_a() -> None:
    a = simulate(paper_model("A", 32.5))
    b_plus = simulate(paper_model("B", 32.5, effects=[make_effect("end_friction:phi_deg=8")]))
    assert np.array_equal(a.contact_points[-1], b_plus.contact_points[-1])


def test_plane_tilt_reseats_the_block_and_changes_the_path() -> None:
    base = simulate(paper_model("B", 40.0))
    tilted = simulate(paper_model("B", 40.0, effects=[make_effect("plane_tilt:dip_dir2_deg=5")]))
    assert tilted.status.label == "travel"
    assert tilted.summary()["max_constraint_residual_m"] < 1e-9
    start_shift = np.abs(tilted.contact_points[0] - base.contact_points[0]).max()
    assert 0 < start_shift < 0.005
    assert np.abs(tilted.contact_points[-1] - base.contact_points[-1]).max() > 1e-3


def test_written_trace_ends_at_the_travel_target(tmp_path: Path) -> None:
    result = simulate(paper_model("A", 32.5))
    path = tmp_path / "trace.csv"
    result.write_csv(path, test_id="A-32.5")
    (test,) = read_measurements(path, rest_positions=SPECIMEN.contact_points_m)
    assert test.shear_force_N == 32.5
    assert test.travel[-1] == pytest.approx(0.08, abs=1e-12)
    assert np.array_equal(test.positions, result.contact_points)


def test_resampling_by_travel_matches_the_trajectory() -> None:
    result = simulate(paper_model("A", 40.0))
    # At the integrator's own rows resampling must return the rows themselves.
    rows = np.arange(5, len(result.t), 7)
    assert np.abs(result.resample_by_travel(result.travel[rows]) - result.contact_points[rows]).max() < 1e-9
    with pytest.raises(ValueError, match="travel"):
        result.resample_by_travel(np.array([0.2]))


def test_result_reports_the_load_point_on_the_face() -> None:
    result = simulate(paper_model("A", 32.5))
    assert np.allclose(result.load_point_on_face[0], [SPECIMEN.load_point_A_m, -SPECIMEN.load_point_B_m])
    # The block climbs while the tip stays at its height: the load point slides down the face.
    assert result.load_point_on_face[-1, 0] < SPECIMEN.load_point_A_m - 1e-3
    hydro = simulate(paper_model("C", 32.5))
    assert np.allclose(hydro.load_point_on_face, hydro.load_point_on_face[0], atol=1e-12)


def test_validation_of_plane_count() -> None:
    with pytest.raises(SpecimenError, match="exactly 3"):
        Foundation((Plane(0.0), Plane(1.0))).validate()
    # CP3 sits at the origin, on every plane; CP2 is off FP2 once FP2 dips another way.
    with pytest.raises(SpecimenError, match="contact_points_m\\[1\\]"):
        SPECIMEN.validate(Foundation((Plane(0.0), Plane(9.5, 170.0), Plane(20.0, 150.0))))


def test_contact_friction_leaves_unset_angles_alone() -> None:
    specimen = replace(SPECIMEN, friction_deg=(20.0, 15.0, 12.0))
    model = paper_model("B", 40.0, specimen=specimen, effects=[make_effect("contact_friction:phi1_deg=16")])
    assert model.specimen.friction_deg == (16.0, 15.0, 12.0)
    rebuilt = EFFECTS["contact_friction"](**make_effect("contact_friction:phi1_deg=16").values)  # as pools do
    assert rebuilt.apply(model).specimen.friction_deg == (16.0, 15.0, 12.0)


@pytest.mark.parametrize("tilt", ["dip1_deg=0.5", "dip1_deg=-1", "dip1_deg=1,dip_dir1_deg=90", "dip_dir2_deg=5"])
def test_small_tilts_of_every_kind_run(tilt: str) -> None:
    result = simulate(paper_model("B", 40.0, effects=[make_effect(f"plane_tilt:{tilt}")]))
    assert result.status.label == "travel", result.message


def test_a_tilt_that_puts_a_point_under_another_plane_is_refused_at_rest() -> None:
    result = simulate(paper_model("B", 40.0, effects=[make_effect("plane_tilt:dip_dir2_deg=-5")]))
    assert result.status.label == "left_plane" and result.t[-1] == 0.0
    assert "starts under FP1" in result.message


@pytest.mark.slow
def test_actuator_rise_starts_at_the_threshold_and_handles_fast_rises() -> None:
    from triplanar.statics import sliding_threshold
    base = paper_model("A", 40.0)
    threshold = sliding_threshold(base)
    for tau in (1e-6, 0.1):
        result = simulate(paper_model("A", 40.0, effects=[make_effect(f"actuator_rise:tau_s={tau}")]))
        assert result.status.label == "travel"
        assert result.thrust[0] == pytest.approx(threshold, rel=1e-9)
        assert result.t_start_s == pytest.approx(-tau * np.log1p(-threshold / 40.0), rel=1e-12)
        assert np.all(np.diff(result.thrust) >= 0) and result.thrust[-1] <= 40.0
    fast = simulate(paper_model("A", 40.0, effects=[make_effect("actuator_rise:tau_s=1e-6")]))
    step = simulate(base)
    assert abs(fast.t[-1] - step.t[-1]) < 1e-4


def test_a_passed_pair_is_remembered_and_a_changed_number_is_checked_again() -> None:
    """A specimen and foundation remember the partners they passed with (a fit's models differ in one number), but
    only those: a block whose numbers changed, or planes that changed, are checked in full."""
    specimen, foundation = reference()
    specimen.validate(foundation)
    same_block = replace(specimen, tip_friction_deg=specimen.tip_friction_deg)   # a new object, the same numbers
    same_block.validate(foundation)
    # the friction angles, which a friction fit changes, are checked every time (the rest of the block is remembered)
    with pytest.raises(SpecimenError, match="tip_friction_deg"):
        replace(specimen, tip_friction_deg=50.0).validate(foundation)
    with pytest.raises(SpecimenError, match=r"friction_deg\[1\]: must lie in \[0, 45\)"):
        replace(specimen, friction_deg=(17.0, -1.0, 11.0)).validate(foundation)
    with pytest.raises(SpecimenError, match="friction_deg: contains NaN"):
        replace(specimen, friction_deg=(17.0, float("nan"), 11.0)).validate(foundation)
    replace(specimen, tip_friction_deg=9.0).validate(foundation)
    with pytest.raises(SpecimenError, match="mass_kg"):
        replace(specimen, mass_kg=-1.0).validate(foundation)
    steep = Foundation(tuple(Plane(p.dip_deg + (5.0 if i == 0 else 0.0), p.dip_direction_deg)
                             for i, p in enumerate(foundation.planes)))
    with pytest.raises(SpecimenError, match=r"contact_points_m\[0\]"):
        specimen.validate(steep)
    with pytest.raises(SpecimenError, match=r"contact_points_m\[0\]"):
        specimen.validate(steep, plane_tolerance_m=1e-6)
