"""The ``cohesion`` effect (Mohr-Coulomb cohesion at the contacts): closed forms on one incline, the
static-equilibrium check, the energy balance, the stuck-contact limit, and the kernel against the independent
natural-coordinate reference."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from triplanar import Foundation, Plane, make_effect, paper_model, reference, simulate
from triplanar import kernel as K
from triplanar.specimen import GRAVITY
from triplanar.statics import holds, sliding_threshold
from triplanar.workbench.candidates import candidate_library

SPECIMEN, _ = reference()
DIP_DEG, PHI_DEG = 30.0, 17.0


def _rotate(points: np.ndarray, axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    rot = np.eye(3)
    rot[i, i], rot[i, j], rot[j, i], rot[j, j] = c, -s, s, c
    return points @ rot.T


def _centred(specimen, along: int):
    """The specimen with its mass centre (and load point) moved along body axis g1 (along = 0) or g3 (2) to the
    contact triangle's centroid: then the constant cohesion forces, which act at the contact points, have the
    same line of action as the mass-centre forces and the block translates (module doc of the tests below)."""
    cps = specimen.contact_points_m
    offset = (cps.mean(axis=0) - cps[0]) @ specimen.body_axes[:, along]
    centre = specimen.mass_centre_m.copy()
    centre[along] = offset
    if along == 2:  # P_CL = P1 + A g2 - B g3
        return replace(specimen, mass_centre_m=centre, load_point_B_m=-offset)
    return replace(specimen, mass_centre_m=centre)


def _down_dip_model(c_N: float):
    """Three identical planes dipping DIP_DEG toward +e3 (the specimen turned about e1), no load: one block on
    one incline. The mass centre sits over the contact centroid's strike coordinate (x)."""
    dip = math.radians(DIP_DEG)
    specimen = replace(SPECIMEN, contact_points_m=_rotate(SPECIMEN.contact_points_m, 0, dip),
                       friction_deg=(PHI_DEG,) * 3)
    specimen = _centred(specimen, 0)
    effects = [make_effect(f"cohesion:c_N={c_N!r}")] if c_N else []
    return paper_model("B", 0.0, specimen=specimen, foundation=Foundation((Plane(DIP_DEG, 90.0),) * 3),
                       effects=effects)


def _critical_cohesion() -> float:
    """Cohesion per contact that just holds the block on the incline: W sin(b) = mu W cos(b) + 3 c."""
    dip = math.radians(DIP_DEG)
    return SPECIMEN.weight_N * (math.sin(dip) - math.tan(math.radians(PHI_DEG)) * math.cos(dip)) / 3.0


@pytest.mark.parametrize("c_N", [0.0, 1.5, 3.5])
def test_single_incline_closed_form(c_N: float) -> None:
    """Sliding down one incline: every point accelerates down-dip at g (sin b - tan(phi) cos b) - 3 c / m.

    Holds exactly only if the block translates: the three cohesion forces act at the contact points, so the
    mass centre must lie over their centroid along the strike (``_centred``); then the normal reactions,
    which are free, balance the moments, and sum to W cos(b)."""
    dip = math.radians(DIP_DEG)
    model = _down_dip_model(c_N)
    result = simulate(model, t_max_s=0.2)
    assert result.status.label == "time_limit", result.message
    expected = GRAVITY * (math.sin(dip) - math.tan(math.radians(PHI_DEG)) * math.cos(dip)) \
        - 3.0 * c_N / SPECIMEN.mass_kg
    assert expected > 0.05  # it does slide (the largest c_N leaves 0.38 m/s^2)
    down_dip = np.array([0.0, -math.sin(dip), math.cos(dip)])
    for row in (1, len(result.t) // 2, -1):
        velocity = result.contact_velocities[row]
        measured = velocity @ down_dip / result.t[row]
        assert np.allclose(measured, expected, rtol=1e-9, atol=0), (measured, expected)
        lateral = velocity - np.outer(velocity @ down_dip, down_dip)
        assert np.abs(lateral).max() < 1e-9 * expected * result.t[row]
    assert abs(result.normal_reactions[-1].sum() - SPECIMEN.weight_N * math.cos(dip)) < 1e-9 * SPECIMEN.weight_N
    # the cohesion's power c |v_i| is dissipated at the contacts: the energy balance stays exact
    energy = result.energy
    dissipated = energy["dissipated_contacts"][-1].sum()
    travel = float(np.linalg.norm(result.contact_points[-1, 0] - result.contact_points[0, 0]))
    mu_w = math.tan(math.radians(PHI_DEG)) * SPECIMEN.weight_N * math.cos(dip)
    assert dissipated == pytest.approx((mu_w + 3.0 * c_N) * travel, rel=1e-9)
    assert np.abs(energy["residual"]).max() <= 1e-9 * dissipated


def test_single_incline_holds_exactly_above_the_closed_form_cohesion() -> None:
    """The static-equilibrium check's widened cones: held from c = c* up (c* closed form), not below; the
    up-dip friction direction is a vertex of the 64-gon, so 0.1 % either side decides."""
    critical = _critical_cohesion()
    assert 3.0 < critical < 5.0
    for factor, held in ((0.999, False), (1.001, True)):
        model = _down_dip_model(factor * critical)
        assert holds(model, model.initial_state(), 0.0) is held, factor
        assert (simulate(model, t_max_s=0.05).status.label == "held") is held, factor


@pytest.mark.parametrize("c_N", [0.0, 0.5, 2.0])
def test_sliding_threshold_shifts_by_three_c(c_N: float) -> None:
    """Pushed up one incline (case C: the thrust along g1 at P_CL, g1 up-dip): the largest thrust held is
    W (sin b + tan(phi) cos b) + 3 c. Mass centre and load point lie over the contact centroid's lateral
    coordinate, so all friction can point down-dip at full strength with the moments balanced."""
    dip = math.radians(DIP_DEG)
    specimen = replace(SPECIMEN, contact_points_m=_rotate(SPECIMEN.contact_points_m, 2, dip),
                       friction_deg=(PHI_DEG,) * 3)
    specimen = _centred(specimen, 2)
    effects = [make_effect(f"cohesion:c_N={c_N!r}")] if c_N else []
    model = paper_model("C", 0.0, specimen=specimen, foundation=Foundation((Plane(DIP_DEG, 180.0),) * 3),
                        effects=effects)
    assert np.allclose(specimen.body_axes[:, 0], [math.cos(dip), math.sin(dip), 0.0])  # g1 is up-dip
    expected = SPECIMEN.weight_N * (math.sin(dip) + math.tan(math.radians(PHI_DEG)) * math.cos(dip)) + 3.0 * c_N
    assert sliding_threshold(model) == pytest.approx(expected, rel=1e-9)


def test_zero_cohesion_changes_nothing() -> None:
    base = simulate(paper_model("A", 32.5))
    zero = simulate(paper_model("A", 32.5, effects=[make_effect("cohesion:c_N=0")]))
    assert np.array_equal(base.y, zero.y) and np.array_equal(base.t, zero.t)


@pytest.mark.parametrize("case, force", [("A", 45.0), ("B", 35.0)])
def test_cohesion_slows_the_paper_cases_and_balances_energy(case: str, force: float) -> None:
    base = simulate(paper_model(case, force))
    coh = simulate(paper_model(case, force, effects=[make_effect("cohesion:c_N=1")]))
    assert coh.status.label == base.status.label == "travel"
    assert coh.t[-1] > base.t[-1] * 1.05
    work = coh.energy["work_load"][-1]
    assert np.abs(coh.energy["residual"]).max() <= 1e-6 * work
    assert (np.diff(coh.energy["dissipated_contacts"], axis=0) >= -1e-12).all()


def test_stuck_contact_gives_way_at_mu_n_plus_c() -> None:
    """A stuck contact's release value is |S| - (mu N + c): cohesion raises the limit by c."""
    model = paper_model("B", 23.0, effects=[make_effect("cohesion:c_N=0.8")])
    y = model.initial_state()
    p = model.kernel_params()
    modes = K.sliding_modes()
    modes[K.M_STUCK] = 2
    modes[K.M_D0:K.M_D0 + 9] = np.tile([1.0, 0.0, 0.0], 3)
    dy, aux = np.empty(K.N_STATE), np.empty(K.N_AUX)
    assert K.rhs(0.0, y, p, modes, dy, aux)
    static = np.linalg.norm(aux[K.A_STICK_F:K.A_STICK_F + 3])
    limit = p[K.P_TANPHI + 2] * aux[K.A_N + 2] + 0.8
    assert aux[K.A_STICK] == pytest.approx(static - limit, abs=1e-12)
    assert dy[K.S_DC + 2] == 0.0  # a stuck contact dissipates nothing


def test_cohesion_is_a_registry_candidate() -> None:
    (cand,) = candidate_library(["cohesion"])
    assert cand.free == ("c_N",) and cand.start_values() == {"c_N": 0.0} and cand.bounds["c_N"] == (0.0, 1.5)
    assert len(cand.grid_values()) == 7
    model = paper_model("A", 30.0, effects=[make_effect("cohesion:c_N=1.25")])
    assert model.setting("cohesion_N") == 1.25 and model.kernel_params()[K.P_COHESION] == 1.25

