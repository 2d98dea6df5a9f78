"""Physics of the core model: closed forms, energy, constraints, similarity, symmetry, convergence,
statics, stick-slip, and agreement with the independent natural-coordinate reference."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from triplanar import (Effect, Foundation, Parameter, Plane, make_effect, paper_model, reference, scale_mass,
                       scale_size, scale_uniform, simulate)
from triplanar import driver, kernel as K, stepping
from triplanar.outcome import Outcome
from triplanar.natural_coordinates import ReferenceModel, reference_accelerations
from triplanar.specimen import GRAVITY, mirrored
from triplanar.statics import holds, sliding_threshold, start_motion

SPECIMEN, FOUNDATION = reference()


def _rotate_about_e1(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return points @ rot.T


# -- closed form ----------------------------------------------------------------------------------

@pytest.mark.parametrize("dip_deg, phi_deg", [(20.0, 10.0), (30.0, 17.0)])
def test_identical_planes_make_a_single_slider_on_an_incline(dip_deg: float, phi_deg: float) -> None:
    """Three identical planes: every point accelerates down-dip at g (sin d - tan(phi) cos d)."""
    dip = math.radians(dip_deg)
    specimen = replace(SPECIMEN, contact_points_m=_rotate_about_e1(SPECIMEN.contact_points_m, dip),
                       friction_deg=(phi_deg,) * 3)
    plane = Plane(dip_deg, 90.0)
    model = paper_model("B", 0.0, specimen=specimen, foundation=Foundation((plane,) * 3))
    result = simulate(model, t_max_s=0.2)
    assert result.status.label == "time_limit"
    expected = GRAVITY * (math.sin(dip) - math.tan(math.radians(phi_deg)) * math.cos(dip))
    down_dip = np.array([0.0, -math.sin(dip), math.cos(dip)])
    for row in (1, len(result.t) // 2, -1):
        velocity = result.contact_velocities[row]            # (3 points, 3)
        measured = velocity @ down_dip / result.t[row]
        assert np.allclose(measured, expected, rtol=1e-9, atol=0)
        lateral = velocity - np.outer(velocity @ down_dip, down_dip)
        assert np.abs(lateral).max() < 1e-9 * expected * result.t[row]
    assert abs(result.normal_reactions[-1].sum() - SPECIMEN.weight_N * math.cos(dip)) < 1e-9 * SPECIMEN.weight_N


def test_identical_planes_steeper_friction_holds() -> None:
    dip = math.radians(20.0)
    specimen = replace(SPECIMEN, contact_points_m=_rotate_about_e1(SPECIMEN.contact_points_m, dip),
                       friction_deg=(21.0,) * 3)
    model = paper_model("B", 0.0, specimen=specimen, foundation=Foundation((Plane(20.0, 90.0),) * 3))
    assert simulate(model).status.label == "held"


# -- energy and constraints -----------------------------------------------------------------------

@pytest.mark.parametrize("case", ["A", "B", "C"])
@pytest.mark.parametrize("force", [27.8, 40.0, 55.6])
def test_energy_balance_and_constraints_along_traces(case: str, force: float) -> None:
    result = simulate(paper_model(case, force))
    assert result.status.label == "travel"
    energy = result.energy
    work = energy["work_load"][-1]
    assert work > 0
    assert np.abs(energy["residual"]).max() <= 1e-6 * work
    assert (np.diff(energy["dissipated_contacts"], axis=0) >= -1e-12).all()
    assert (np.diff(energy["dissipated_tip"]) >= -1e-12).all()
    assert result.summary()["max_constraint_residual_m"] < 1e-9
    assert np.isfinite(result.y).all() and np.isfinite(result.aux).all()


def test_case_b_tip_does_no_dissipation_and_case_a_does() -> None:
    assert simulate(paper_model("B", 32.5)).energy["dissipated_tip"][-1] == 0.0
    assert simulate(paper_model("A", 32.5)).energy["dissipated_tip"][-1] > 0.01


@pytest.mark.parametrize("method, dt", [("rk4", 1e-3), ("euler", 2e-5)])
def test_fixed_step_methods_keep_constraints(method: str, dt: float) -> None:
    result = simulate(paper_model("A", 40.0), method=method, dt=dt)
    assert result.status.label == "travel"
    assert result.summary()["max_constraint_residual_m"] < 1e-9


# -- start, hold, stick, arrest -------------------------------------------------------------------

def test_reference_specimen_holds_at_20_N_and_slides_at_27_8_N() -> None:
    assert simulate(paper_model("A", 20.0)).status.label == "held"
    result = simulate(paper_model("A", 27.8))
    assert result.status.label == "travel"
    assert result.travel[-1] == pytest.approx(0.08, abs=1e-12)


def test_sliding_threshold_separates_hold_from_slide() -> None:
    model = paper_model("A", 30.0)
    threshold = sliding_threshold(model)
    assert 20.0 < threshold < 27.8
    assert simulate(replace(model, loading=replace(model.loading, force_N=threshold - 0.05))).status.label == "held"
    assert simulate(replace(model, loading=replace(model.loading, force_N=threshold + 0.05))).status.label != "held"


def test_end_friction_raises_the_threshold() -> None:
    assert sliding_threshold(paper_model("A", 30.0)) > sliding_threshold(paper_model("B", 30.0)) + 1.0


class _Pulse(Effect):
    """Test-only: a push at the mass centre for the first 50 ms."""
    name = "pulse_for_test"
    parameters = {"force_N": Parameter(20.0, 0.0, 100.0, "N", "pulse along e1")}

    def wrench(self, t, state):
        return (np.array([self["force_N"], 0.0, 0.0]) if t < 0.05 else np.zeros(3)), np.zeros(3)


def test_a_block_pushed_below_threshold_by_a_pulse_arrests() -> None:
    model = paper_model("B", 15.0, effects=[_Pulse(force_N=20.0)])
    result = simulate(model, t_max_s=2.0)
    assert result.status.label == "arrested", result.message
    assert result.t[-1] < 1.0
    assert holds(model, result.y[-1], t=result.t[-1])
    # Energy: the pulse's work is all dissipated or stored (potential), none left as motion.
    e = result.energy
    assert e["work_other"][-1] > 0
    assert abs(e["residual"][-1]) < 1e-6 * (e["work_other"][-1] + e["work_load"][-1])
    assert e["kinetic"][-1] < 1e-9


def test_user_effect_with_zero_force_changes_nothing() -> None:
    base = simulate(paper_model("A", 32.5))
    zero = simulate(paper_model("A", 32.5, effects=[_Pulse(force_N=0.0)]))
    assert zero.status.label == base.status.label
    assert np.abs(zero.contact_points[-1] - base.contact_points[-1]).max() < 1e-12


def test_pivot_start_below_the_paper_range() -> None:
    """At 23 N without end friction, all-sliding start is inconsistent: CP3 sticks and the block pivots
    about it until its friction gives way."""
    result = simulate(paper_model("B", 23.0))
    assert result.status.label in {"left_plane", "travel"}
    speeds = np.linalg.norm(result.contact_velocities, axis=2)
    early = result.t < 0.3
    assert speeds[early, 2].max() < 1e-9 < speeds[early, 0].max()
    assert len(result.t) < 5000


# -- other endings --------------------------------------------------------------------------------

def test_lift_off_at_high_thrust() -> None:
    result = simulate(paper_model("A", 150.0))
    assert result.status.label == "lift_off"
    assert "CP2" in result.message
    assert result.normal_reactions[-1, 1] == pytest.approx(0.0, abs=1e-6)


def test_mass_centre_leaving_the_triangle() -> None:
    specimen = replace(SPECIMEN, mass_centre_m=np.array([0.07, 0.022, -0.001]))
    result = simulate(paper_model("B", 40.0, specimen=specimen))
    assert result.status.label == "mass_centre_outside"


def test_contact_point_leaving_its_plane() -> None:
    result = simulate(paper_model("B", 23.0))
    assert result.status.label == "left_plane" and "CP3 crossed onto FP2" in result.message
    cp3 = result.contact_points[-1, 2]  # located where it is LEFT_PLANE_TOL under FP2
    assert FOUNDATION.planes[1].height(cp3[0], cp3[2]) - cp3[1] == pytest.approx(K.LEFT_PLANE_TOL, abs=1e-10)


def test_time_limit() -> None:
    result = simulate(paper_model("A", 32.5), t_max_s=0.1)
    assert result.status.label == "time_limit" and result.t[-1] == pytest.approx(0.1, abs=1e-12)


# -- similarity (cases D, E, F) -------------------------------------------------------------------

def _paths_at(result, travels):
    return result.resample_by_travel(travels)


@pytest.mark.parametrize("case", ["A", "B"])
def test_case_d_size_scaling_doubles_the_path(case: str) -> None:
    base = simulate(paper_model(case, 40.0))
    big = simulate(paper_model(case, 40.0, specimen=scale_size(SPECIMEN, 2.0)), travel_m=0.16)
    travels = np.linspace(0.0, 0.08, 17)
    a, b = _paths_at(base, travels), _paths_at(big, 2 * travels)
    assert np.abs(b - 2 * a).max() <= 1e-6 * 0.16
    assert np.allclose(big.time_at_travel(2 * travels), math.sqrt(2) * base.time_at_travel(travels), rtol=1e-6,
                       atol=1e-9)


@pytest.mark.parametrize("d", [0.5, 2.0])
def test_case_e_mass_scaling_gives_identical_paths(d: float) -> None:
    base = simulate(paper_model("A", 40.0))
    heavy = simulate(paper_model("A", 40.0 * d, specimen=scale_mass(SPECIMEN, d)))
    travels = np.linspace(0.0, 0.08, 17)
    assert np.abs(_paths_at(heavy, travels) - _paths_at(base, travels)).max() <= 1e-9
    assert np.allclose(heavy.time_at_travel(travels), base.time_at_travel(travels), rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("c", [0.5, 2.0])
def test_case_f_uniform_scaling_is_geometrically_similar(c: float) -> None:
    scaled_specimen = scale_uniform(SPECIMEN, c)
    base = simulate(paper_model("A", SPECIMEN.weight_N / 2))
    scaled = simulate(paper_model("A", scaled_specimen.weight_N / 2, specimen=scaled_specimen), travel_m=0.08 * c)
    travels = np.linspace(0.0, 0.08, 17)
    assert np.abs(_paths_at(scaled, c * travels) - c * _paths_at(base, travels)).max() <= 1e-6 * 0.08 * c
    assert np.allclose(scaled.time_at_travel(c * travels), math.sqrt(c) * base.time_at_travel(travels), rtol=1e-6,
                       atol=1e-9)


# -- mirror symmetry ------------------------------------------------------------------------------

@pytest.mark.parametrize("case", ["A", "B", "C"])
def test_mirroring_in_x3_mirrors_the_traces(case: str) -> None:
    spec_m, found_m = mirrored(SPECIMEN, FOUNDATION)
    base = simulate(paper_model(case, 35.0))
    mirror = simulate(paper_model(case, 35.0, specimen=spec_m, foundation=found_m))
    assert mirror.status.label == base.status.label == "travel"
    travels = np.linspace(0.0, 0.08, 21)
    flip = np.array([1.0, 1.0, -1.0])
    assert np.abs(mirror.resample_by_travel(travels) - base.resample_by_travel(travels) * flip).max() < 1e-9
    assert mirror.rotation_deg[-1] == pytest.approx(-base.rotation_deg[-1], abs=1e-7)


# -- convergence ----------------------------------------------------------------------------------

def _state_at(method: str, dt: float | None, t_end: float = 0.15) -> np.ndarray:
    kwargs = {"rtol": 1e-12, "atol": 1e-14} if method == "dopri5" else {"dt": dt}
    result = simulate(paper_model("B", 40.0), method=method, t_max_s=t_end, **kwargs)
    assert result.status.label == "time_limit"
    return result.contact_points[-1]


def test_paper_euler_converges_with_first_order() -> None:
    exact = _state_at("dopri5", None)
    errors = [np.abs(_state_at("euler", dt) - exact).max() for dt in (2e-4, 1e-4, 5e-5)]
    ratios = [errors[i] / errors[i + 1] for i in range(2)]
    assert all(1.7 < r < 2.3 for r in ratios), (errors, ratios)


def _integrate(t0: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray, armed: np.ndarray, h: float,
               opts: stepping.StepOptions, rec: stepping.Recording):
    """:func:`triplanar.stepping.integrate` (``modes`` updated in place), through the compiled function the library
    calls, ``integrate_ws``, which ``make install`` puts in numba's cache: ``integrate`` has no caller in the library,
    so calling it compiles it again in each test process (20 s of CPU)."""
    ws = driver.new_workspace()
    ws[K.W_MODES, :K.N_MODE] = modes
    out = stepping.integrate_ws(t0, y, p, armed, h, opts, rec, 0, ws)
    modes[:] = ws[K.W_MODES, :K.N_MODE]
    return out


def _no_recording() -> stepping.Recording:
    return stepping.Recording(False, np.empty(1), np.empty((1, K.N_STATE)), np.empty((1, K.N_STATE)),
                              np.empty((1, K.N_AUX)), np.empty((0, 3)))


def _integrate_from(y0: np.ndarray, p: np.ndarray, method: int, h: float, t0: float = 0.05,
                    t1: float = 0.15) -> np.ndarray:
    y = y0.copy()
    _integrate(t0, y, p.copy(), K.sliding_modes(), np.ones(5, np.bool_), h,
                       stepping.StepOptions(method, 1e-12, 1e-14, t1, 10.0, 1e-5, 0.0), _no_recording())
    return y[K.S_R:K.S_R + 3]


def test_rk4_converges_with_fourth_order_on_smooth_motion() -> None:
    """From a moving state (smooth right-hand side) RK4 shows its order 4."""
    model = paper_model("B", 40.0)
    y0 = simulate(model, rtol=1e-12, atol=1e-14, t_max_s=0.05).y[-1]
    p = model.kernel_params()
    exact = _integrate_from(y0, p, stepping.METHOD_DOPRI5, 1e-4)
    errors = [np.abs(_integrate_from(y0, p, stepping.METHOD_RK4, h) - exact).max() for h in (1e-2, 5e-3, 2.5e-3)]
    ratios = [errors[i] / errors[i + 1] for i in range(2)]
    assert all(14 < r < 17 for r in ratios), (errors, ratios)


def test_rk4_from_rest_is_third_order() -> None:
    """Starting from rest, friction's direction v/|v| is not smooth at v = 0: RK4's global error from
    rest falls as h^3 (documented in docs/physics.md), not h^4."""
    exact = _state_at("dopri5", None)
    errors = [np.abs(_state_at("rk4", dt) - exact).max() for dt in (1.5e-2, 7.5e-3, 3.75e-3)]
    ratios = [errors[i] / errors[i + 1] for i in range(2)]
    assert all(6.5 < r < 9.5 for r in ratios), (errors, ratios)


def test_default_dopri5_is_accurate_to_a_micrometre() -> None:
    for case, force in (("A", 27.8), ("B", 32.5), ("C", 55.6)):
        default = simulate(paper_model(case, force))
        tight = simulate(paper_model(case, force), rtol=1e-12, atol=1e-15)
        travels = np.linspace(0, 0.08, 41)
        assert np.abs(default.resample_by_travel(travels) - tight.resample_by_travel(travels)).max() < 1e-6


# -- the kernel against the independent natural-coordinate reference ------------------------------

def _reference_model(model, tip_offset: float, tip_rate: float) -> ReferenceModel:
    s = model.specimen
    g = s.body_axes
    return ReferenceModel(cp_rest=s.contact_points_m, mass=s.mass_kg, com_rest=s.mass_centre_world,
                          inertia_rest=g @ s.inertia_kg_m2 @ g.T, normals=model.foundation.normals,
                          tan_phi=np.tan(np.radians(s.friction_deg)), load_case=model.loading.kind,
                          force=model.loading.force_N, tan_phi_ef=model.tan_phi_EF, A=s.load_point_A_m,
                          B=s.load_point_B_m, tip_offset=tip_offset, tip_offset_rate=tip_rate,
                          contact_laws=model.effects, gravity=GRAVITY)


@pytest.mark.parametrize("case, effects, tip_rate", [
    ("A", [], 0.0), ("B", [], 0.0), ("C", [], 0.0),
    ("A", ["rate_friction:a=0.3,v0_m_s=0.01", "tip_offset:offset_m=0.01"], 0.05),
    ("A", ["cohesion:c_N=1.5", "rate_friction:a=0.3,v0_m_s=0.01"], 0.0), ("C", ["cohesion:c_N=2.5"], 0.0),
])
def test_kernel_matches_natural_coordinate_reference(case: str, effects: list[str], tip_rate: float) -> None:
    model = paper_model(case, 45.0, effects=[make_effect(e) for e in effects])
    result = simulate(model)
    p = model.kernel_params()
    p[K.P_UDOT] = tip_rate
    ref = _reference_model(model, 0.0, tip_rate)
    checked = 0
    for row in np.linspace(len(result.t) // 4, len(result.t) - 1, 5).astype(int):
        y = result.y[row].copy()
        if np.linalg.norm(result.contact_velocities[row], axis=1).min() < 1e-3:
            continue
        dy, aux = np.empty(K.N_STATE), np.empty(K.N_AUX)
        assert K.rhs(0.0, y, p, K.sliding_modes(), dy, aux)
        if case == "A" and np.linalg.norm(aux[K.A_SLIP:K.A_SLIP + 3]) < 1e-3:
            continue
        arms = result.contact_points[row] - y[K.S_R:K.S_R + 3]
        w, alpha = y[K.S_W:K.S_W + 3], dy[K.S_W:K.S_W + 3]
        acc = dy[K.S_V:K.S_V + 3] + np.cross(alpha, arms) + np.cross(w, np.cross(w, arms))
        ref_ = replace(ref, tip_offset=float(y[K.S_U]))
        ref_acc, ref_n = reference_accelerations(ref_, result.contact_points[row], result.contact_velocities[row])
        scale = np.abs(ref_acc).max()
        assert np.abs(acc - ref_acc).max() < 1e-9 * scale
        assert np.allclose(aux[K.A_N:K.A_N + 3], ref_n, rtol=1e-9, atol=1e-9)
        checked += 1
    assert checked >= 3


class _ThrustDrop(Effect):
    """Test-only: a pull at the mass centre from t = 0.2 s that leaves less than the holding force."""
    name = "thrust_drop_for_test"
    parameters = {"force_N": Parameter(8.3, 0.0, 50.0, "N", "pull along -e1 after 0.2 s")}

    def wrench(self, t, state):
        return (np.array([-self["force_N"], 0.0, 0.0]) if t > 0.2 else np.zeros(3)), np.zeros(3)


def test_a_sliding_block_whose_drive_drops_arrests_without_creep() -> None:
    """Regression: a slowing contact used to keep a stale low-speed friction direction and creep at
    micrometres per second for ever; it must decelerate, stop and be held."""
    result = simulate(paper_model("A", 27.8, effects=[_ThrustDrop()]), t_max_s=3.0)
    assert result.status.label == "arrested", result.message
    assert result.t[-1] < 0.5
    assert np.abs(result.energy["residual"]).max() < 1e-9


def test_fixed_steps_stop_where_a_slip_stops() -> None:
    """The drive drops to 10 N while the block slides: friction stops it. A fixed RK4 step steps to each
    predicted stop instead of stepping over it (where the slip would reverse and creep on), so even 5 ms steps
    end in the all-slow state the statics decide, close to the adaptive solution, and converge with the step."""
    model = paper_model("A", 40.0)
    sliding = simulate(model, travel_m=0.01)
    y0, p0, modes0 = sliding.y[-1].copy(), model.kernel_params().copy(), K.sliding_modes()
    start_motion(p0, modes0, model.initial_state())
    p0[K.P_FCMD] = 10.0

    def stop(method: int, h: float) -> tuple[int, np.ndarray, float]:
        y, p = y0.copy(), p0.copy()
        opts = stepping.StepOptions(method, 1e-11, 1e-14, sliding.t[-1] + 1.0, 10.0, 1e-5, 0.0)
        status, _, _, _, t = _integrate(sliding.t[-1], y, p, modes0.copy(), np.ones(5, np.bool_), h, opts,
                                                _no_recording())
        cps = np.empty((3, 3))
        K.contact_points(y, p, cps)
        return status, cps, t

    status, exact, t_exact = stop(stepping.METHOD_DOPRI5, 1e-4)
    assert status == Outcome.SLOW and holds(model, y0, 10.0)
    errors = []
    for h in (5e-3, 1e-3):
        status, cps, t = stop(stepping.METHOD_RK4, h)
        assert status == Outcome.SLOW and abs(t - t_exact) < 0.5 * h
        errors.append(np.abs(cps - exact).max())
    assert errors[0] < 2e-6 and errors[1] < errors[0] / 10  # m


def test_a_turning_slip_does_not_stall_fixed_steps() -> None:
    """A state from a PPO rollout (tests/data/turning_slip_state.npz): CP3 slips at 1.2 mm/s and decelerates, but
    its slip turns instead of stopping. Predicting its stop again and again used to shrink the steps towards zero
    (the env stalled); a site whose predicted stop was not one is not predicted again in the same call. The state
    was recorded before the kernel had cohesion (``P_COHESION``, its last parameter): that model had none, so the
    parameters are padded with zero. Unpadded, the compiled code read whatever lay past the array as the cohesion,
    and the test failed now and then (integration failed instead of the time limit)."""
    d = np.load(Path(__file__).resolve().parents[1] / "data" / "turning_slip_state.npz")
    y = d["y"].copy()
    assert len(d["p"]) == K.P_COHESION == K.N_PARAM - 1  # the layout this padding is for
    p = np.concatenate([d["p"], [0.0]])
    rec = stepping.Recording(True, np.empty(1000), np.empty((1000, K.N_STATE)), np.empty((1000, K.N_STATE)),
                             np.empty((1000, K.N_AUX)), np.empty((0, 3)))
    opts = stepping.StepOptions(stepping.METHOD_RK4, 0.0, 0.0, float(d["t_end"]), float(d["x1_target"]),
                                float(d["slow_speed"]), 0.0)
    status, _, rows, _, t = _integrate(float(d["t0"]), y, p, d["modes"].copy(), d["armed"].copy(),
                                               float(d["h"]), opts, rec)
    assert status == Outcome.TIME_LIMIT and t == pytest.approx(float(d["t_end"]), abs=1e-12)
    assert rows <= stepping.MAX_MISSED_STOPS + 5
