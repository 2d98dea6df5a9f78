"""Tests of the natural-coordinate Lagrangian reference (triplanar/natural_coordinates.py).

The checks are independent of the module's internals: forces, frames, momenta and energies are
recomputed here with plain rigid-body (Newton-Euler) formulas.
"""
from __future__ import annotations


import numpy as np
import pytest

from triplanar.effects import make_effect
from triplanar.natural_coordinates import ReferenceModel, reference_accelerations, reference_simulate

G = 9.81
E1, E2, E3 = np.eye(3)
L12, L23 = 0.14, 0.24
CP_REST = np.array([[-L12, 0.0, L23], [0.0, 0.0, L23], [0.0, 0.0, 0.0]])
MASS = 5.4
COM_REST = CP_REST[0] + np.array([0.115, 0.022, -0.120])
I_REST = np.diag([0.04139, 0.05063, 0.01101])
A_LOAD, B_LOAD = 0.015, 0.12


def plane_normal(dip: float, dd: float) -> np.ndarray:
    d, a = np.radians(dip), np.radians(dd)
    return np.array([np.sin(d) * np.cos(a), np.cos(d), np.sin(d) * np.sin(a)])


NORMALS = np.array([plane_normal(0, 0), plane_normal(9.5, 180), plane_normal(20, 150)])


def skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def rotation(theta: np.ndarray) -> np.ndarray:
    th = np.linalg.norm(theta)
    if th == 0:
        return np.eye(3)
    K = skew(theta / th)
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def specimen(**kw) -> ReferenceModel:
    args = dict(cp_rest=CP_REST, mass=MASS, com_rest=COM_REST, inertia_rest=I_REST,
                normals=NORMALS, tan_phi=np.zeros(3), A=A_LOAD, B=B_LOAD)
    args.update(kw)
    return ReferenceModel(**args)


def frame(P: np.ndarray) -> np.ndarray:
    """Rotation from rest to current, columns g1, g2, g3 (rest frame is e1, e2, e3)."""
    g1 = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    g2 = np.cross(P[1] - P[0], P[2] - P[0])
    g2 /= np.linalg.norm(g2)
    return np.column_stack([g1, g2, np.cross(g1, g2)])


def omega_of(P: np.ndarray, V: np.ndarray) -> np.ndarray:
    A = np.vstack([-skew(P[i] - P[0]) for i in (1, 2)])
    return np.linalg.lstsq(A, np.concatenate([V[1] - V[0], V[2] - V[0]]), rcond=None)[0]


def energy(P: np.ndarray, V: np.ndarray) -> tuple[float, float]:
    R = frame(P)
    w = omega_of(P, V)
    c = P[0] + R @ (COM_REST - CP_REST[0])
    vc = V[0] + np.cross(w, c - P[0])
    ke = 0.5 * MASS * vc @ vc + 0.5 * w @ (R @ I_REST @ R.T) @ w
    return ke, MASS * G * c[1]


def admissible_state(theta, pick):
    """Rigidly moved specimen on the three planes, with a rigid velocity tangent to them."""
    R = rotation(np.asarray(theta, float))
    t = np.linalg.solve(NORMALS, -np.einsum("ij,ij->i", NORMALS, CP_REST @ R.T))
    P = CP_REST @ R.T + t
    # unknowns (v1, w): V_i = v1 + w x (P_i - P1) with n_i . V_i = 0
    A = np.array([np.concatenate([n, np.cross(P[i] - P[0], n)]) for i, n in enumerate(NORMALS)])
    basis = np.linalg.svd(A)[2][3:]
    x = np.asarray(pick, float) @ basis
    v1, w = x[:3], x[3:]
    V = np.array([v1 + np.cross(w, p - P[0]) for p in P])
    return R, P, V, w


def newton_euler_residual(model, R, P, V, w, Pdd, N, dirs, f_ext, m_ext):
    """Check Pdd, N against m a_c = sum F and I alpha + w x I w = sum M (independent formulas)."""
    r = [P[i] - P[0] for i in (1, 2)]
    A = np.vstack([-skew(ri) for ri in r])
    b = np.concatenate([Pdd[i] - Pdd[0] - np.cross(w, np.cross(w, r[i - 1])) for i in (1, 2)])
    alpha, *_ = np.linalg.lstsq(A, b, rcond=None)
    rigid_misfit = np.linalg.norm(A @ alpha - b)
    c = P[0] + R @ (COM_REST - CP_REST[0])
    a_c = Pdd[0] + np.cross(alpha, c - P[0]) + np.cross(w, np.cross(w, c - P[0]))
    forces = [(c, -MASS * G * E2 + f_ext)]
    for i in range(3):
        sp = np.linalg.norm(V[i])
        rate_a = RATE_A if model.contact_laws else 0.0  # the rate law of the models below, recomputed here
        mu = model.tan_phi[i] * (1 + rate_a * np.log(1 + sp / RATE_V0))
        d = V[i] / sp if sp >= 1e-12 else dirs[i]
        forces.append((P[i], N[i] * NORMALS[i] - mu * N[i] * d))
    g1, g2, g3 = R.T
    p_cl = P[0] + A_LOAD * g2 - B_LOAD * g3
    if model.load_case == "hydrostatic":
        forces.append((p_cl, model.force * g1))
    else:
        T = np.array([-L12, A_LOAD, L23 - B_LOAD]) + model.tip_offset * E3
        p_l = T + (p_cl - T) @ g1 / g1[0] * E1
        forces.append((p_l, model.force * E1))
        v_l = V[0] + np.cross(w, p_l - P[0])
        ws = v_l - model.tip_offset_rate * E3
        ws = ws - ws @ g1 / g1[0] * E1
        d = ws / np.linalg.norm(ws) if np.linalg.norm(ws) >= 1e-12 else dirs[3]
        forces.append((p_l, -model.force * g1[0] * model.tan_phi_ef * d))
    I_w = R @ I_REST @ R.T
    f_res = MASS * a_c - sum(f for _, f in forces)
    m_res = I_w @ alpha + np.cross(w, I_w @ w) - sum(np.cross(x - c, f) for x, f in forces) - m_ext
    return rigid_misfit, f_res, m_res


RATE_A, RATE_V0 = 0.05, 1e-3
CASE_A = dict(load_case="actuator", force=40.0, tan_phi_ef=np.tan(np.radians(8)),
              tan_phi=np.tan(np.radians([17.0, 14.0, 11.0])), tip_offset=0.004, tip_offset_rate=0.02,
              contact_laws=(make_effect(f"rate_friction:a={RATE_A},v0_m_s={RATE_V0}"),))


@pytest.mark.parametrize("kw", [
    CASE_A,
    dict(CASE_A, tan_phi_ef=0.0, tip_offset_rate=0.0),
    dict(load_case="hydrostatic", force=35.0, tan_phi=np.tan(np.radians([17.0, 14.0, 11.0]))),
])
@pytest.mark.parametrize("moving", [True, False])
def test_newton_euler_and_rigidity(kw, moving):
    model = specimen(**kw)
    R, P, V, w = admissible_state([0.03, -0.06, 0.02], [0.3, -0.2, 0.25])
    if not moving:
        V, w = np.zeros((3, 3)), np.zeros(3)
    dirs = np.array([[1.0, 0, 0], [0.6, 0, 0.8], [0, 0, 1.0], [0, 0.6, -0.8]])
    f_ext, m_ext = np.array([1.5, -2.0, 0.7]), np.array([0.3, -0.1, 0.25])
    Pdd, N = reference_accelerations(model, P, V, dirs, f_ext, m_ext)
    assert np.all(N > 0)
    # second derivatives of |Pi - Pj|^2 and of n_i . P_i vanish
    for i, j in ((0, 1), (0, 2), (1, 2)):
        d2 = 2 * ((V[i] - V[j]) @ (V[i] - V[j]) + (P[i] - P[j]) @ (Pdd[i] - Pdd[j]))
        assert abs(d2) < 1e-10
    assert np.max(np.abs(np.einsum("ij,ij->i", NORMALS, Pdd))) < 1e-10
    misfit, f_res, m_res = newton_euler_residual(model, R, P, V, w, Pdd, N, dirs, f_ext, m_ext)
    assert misfit < 1e-10
    assert np.linalg.norm(f_res) < 1e-9 * MASS * G
    assert np.linalg.norm(m_res) < 1e-9 * MASS * G * 0.1


@pytest.mark.parametrize("rate_a", [0.0, 0.2])
def test_single_inclined_plane_closed_form(rate_a):
    dip = 20.0
    n = plane_normal(dip, 90.0)
    axis = np.cross(E2, n)
    R = rotation(axis / np.linalg.norm(axis) * np.radians(dip))
    assert np.allclose(R @ E2, n)
    mu0 = np.tan(np.radians(10.0))
    model = ReferenceModel(cp_rest=CP_REST @ R.T, mass=MASS, com_rest=R @ COM_REST,
                           inertia_rest=R @ I_REST @ R.T, normals=np.tile(n, (3, 1)),
                           tan_phi=np.full(3, mu0), load_case="hydrostatic", force=0.0,
                           contact_laws=(make_effect(f"rate_friction:a={rate_a},v0_m_s=0.001"),))
    down = np.array([0.0, -np.sin(np.radians(dip)), np.cos(np.radians(dip))])  # dip direction e3
    assert abs(down @ n) < 1e-15
    v0 = 0.01
    Pdd, N = reference_accelerations(model, CP_REST @ R.T, np.tile(v0 * down, (3, 1)))
    mu = mu0 * (1 + rate_a * np.log(1 + v0 / 1e-3))
    a = G * (np.sin(np.radians(dip)) - mu * np.cos(np.radians(dip)))
    for row in Pdd:
        assert np.linalg.norm(row - a * down) <= 1e-9 * abs(a)
    assert abs(N.sum() - MASS * G * np.cos(np.radians(dip))) <= 1e-9 * MASS * G
    assert np.all(N > 0)


def _constraint_residual(P: np.ndarray) -> float:
    L2 = [np.sum((CP_REST[i] - CP_REST[j]) ** 2) for i, j in ((0, 1), (0, 2), (1, 2))]
    res = [np.abs(np.einsum("kij,ij->ki", P, NORMALS)).max()]
    for (i, j), l2 in zip(((0, 1), (0, 2), (1, 2)), L2):
        res.append(np.abs(np.sum((P[:, i] - P[:, j]) ** 2, axis=1) - l2).max())
    return max(res)


@pytest.mark.slow
def test_energy_conserved_frictionless_gravity_only():
    # The foundation climbs toward +e1: released frictionless, the block slides back under gravity.
    t, P, V = reference_simulate(specimen(load_case="hydrostatic", force=0.0), 0.2, 1e-4)
    ke, pe = np.array([energy(p, v) for p, v in zip(P, V)]).T
    assert ke.max() > 1e-2  # it really moves
    assert np.max(np.abs(ke + pe - ke[0] - pe[0])) < 1e-10 * ke.max()
    assert _constraint_residual(P) < 1e-12


@pytest.mark.slow
def test_work_of_hydrostatic_load_equals_energy_gain():
    F = 40.0
    t, P, V = reference_simulate(specimen(load_case="hydrostatic", force=F), 0.2, 1e-4)
    power = []
    for p, v in zip(P, V):
        R = frame(p)
        w = omega_of(p, v)
        r = A_LOAD * R[:, 1] - B_LOAD * R[:, 2]
        power.append(F * R[:, 0] @ (v[0] + np.cross(w, r)))
    power = np.array(power)
    h = t[1] - t[0]
    assert (len(t) - 1) % 2 == 0
    work = h / 3 * (power[0] + power[-1] + 4 * power[1:-1:2].sum() + 2 * power[2:-1:2].sum())
    (ke0, pe0), (ke1, pe1) = energy(P[0], V[0]), energy(P[-1], V[-1])
    assert ke1 > 0.1
    assert abs(work - (ke1 + pe1 - ke0 - pe0)) < 1e-10 * work


def test_case_a_simulation_stays_on_constraints_and_moves_forward():
    model = specimen(**CASE_A)
    dirs = np.array([E1, E1, E1, np.zeros(3)])
    t, P, V = reference_simulate(model, 0.05, 1e-4, rest_directions=dirs)
    assert _constraint_residual(P) < 1e-12
    vel_res = max(np.abs(np.einsum("kij,ij->ki", V, NORMALS)).max(),
                  *(np.abs(np.einsum("kj,kj->k", P[:, i] - P[:, j], V[:, i] - V[:, j])).max()
                    for i, j in ((0, 1), (0, 2), (1, 2))))
    assert vel_res < 1e-12
    assert np.all(V[1:, :, 0] > 0)  # every contact point moves forward under 40 N
    assert t[-1] == pytest.approx(0.05, abs=0)
