"""Independent reference dynamics of the tri-planar block (Galic, Glaser & Goodman 2008, sec. 3.2-3.5).

Pure numpy, no imports from the rest of the project: it exists to be compared with the fast
Newton-Euler kernel.  It uses the paper's Lagrangian, constrained-coordinate form (eq. 39) in
*natural coordinates*  q = (P1, P2, P3, u) in R^12.

Why this is the paper's model.  The paper's q1..q9 are the coordinates of P1, P2, P3 (eq. 8).  Its
mass matrix M(q) is configuration dependent because g2 and g3 are nonlinear in P1..P3.  We add the
triangle's unit normal u = g2 as three more coordinates, with three more constraints (u.u = 1,
u.(P2-P1) = 0, u.(P3-P1) = 0).  On the constraint manifold u is the function (P2-P1)x(P3-P1)/|..| of
P1..P3 (the sign is fixed by continuity from rest), so the set of admissible configurations, the
kinetic energy and the virtual work of every force are the paper's; by d'Alembert-Lagrange the
motion is the same.  What changes: every body point is now LINEAR in q, so M is constant and the
velocity terms of eq. 37 vanish (they reappear in the constraint term -(dPhi_q/dt) qdot).

Body points.  With d2 = P2-P1, d3 = P3-P1 and D = [d2 | d3 | u] (3x3), a body point x has constant
coefficients (a, b, c) = D^-1 (x - P1) (computed at rest), and x = C(a,b,c) q with
C = [(1-a-b) I3, a I3, b I3, c I3] = w^T (x) I3, w = (1-a-b, a, b, c).  A body-fixed direction
(g1, g3) has coefficients D^-1 g and C = [(-a-b) I3, a I3, b I3, c I3].

Mass matrix.  T = 1/2 int |xdot|^2 dm = 1/2 qdot^T M qdot with M = int C^T C dm = (int w w^T dm) (x) I3.
w is affine in x: w(x) = w(x_c) + W (x - x_c), W = dw/dx = Tm D^-1 with
Tm = [[-1,-1,0],[1,0,0],[0,1,0],[0,0,1]].  Since int (x - x_c) dm = 0,
    int w w^T dm = m w_c w_c^T + W J W^T,   J = int (x-x_c)(x-x_c)^T dm = tr(I_c)/2 * I3 - I_c,
the second-moment tensor about the mass centre (I_c = tr(J) I3 - J, so tr(I_c) = 2 tr(J)).

Constraints (9): n_i.P_i = 0 (i = 1..3); |d2|^2 = L12^2, |d3|^2 = L13^2, |P3-P2|^2 = L23^2;
u.u = 1; u.d2 = 0; u.d3 = 0.  Equations of motion (eq. 39, no Baumgarte terms):
    M qdd - Phi_q^T lam - sum_i s_i lam_i = Q,     Phi_q qdd = -(dPhi_q/dt) qdot,
where the generalized force of the plane multiplier lam_i is n_i in the P_i slot, i.e. a force
lam_i n_i at CP i: lam_i = N_i, the normal reaction (eq. 18-20).  Coulomb friction
S_i = -mu_i N_i v_i/|v_i| is proportional to lam_i, so (paper eq. 21-23, 35) its generalized force
lam_i s_i, s_i = -mu_i v_i/|v_i| in the P_i slot, is moved into the matrix; a constant part c_i of the
shear strength (mu_i N_i + c_i, the effects' contact law) stays in Q.  A force F at a body
point with matrix C contributes C^T F to Q; a moment Mo contributes sum_k 1/2 G_k^T (Mo x g_k)
(G_k: the matrices of g1, g2, g3; this is a statically equivalent couple of point forces).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

E1, E2, E3 = np.eye(3)
V_EPS = 1e-12  # speeds below this use the caller-given rest directions
_TM = np.array([[-1.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, eq=False)
class ReferenceModel:
    cp_rest: np.ndarray            # (3,3) rest positions of CP1..CP3 (rows), world, m
    mass: float                    # kg
    com_rest: np.ndarray           # (3,) mass centre at rest, world
    inertia_rest: np.ndarray       # (3,3) inertia about the mass centre at rest, world axes
    normals: np.ndarray            # (3,3) unit upward normals of FP1..FP3 (rows)
    tan_phi: np.ndarray            # (3,) contact friction coefficients
    load_case: str = "actuator"    # "actuator" or "hydrostatic"
    force: float = 0.0             # F, N
    tan_phi_ef: float = 0.0        # end friction coefficient (0 = off)
    A: float = 0.0                 # P_CL = P1 + A g2 - B g3 (eq. 27)
    B: float = 0.0
    tip_offset: float = 0.0        # u_tip: tip line passes through P0_CL + u_tip e3, direction e1
    tip_offset_rate: float = 0.0   # d(u_tip)/dt, m/s
    # The contact friction law as the effects describe it: objects with contact_strength(mu, c, speed)
    # -> (mu, c) (triplanar.effects.Effect; pass the model's effects), applied in turn from (tan_phi_i, 0).
    # A sliding contact resists with mu_i N_i + c_i.
    contact_laws: tuple = ()
    gravity: float = 9.81          # along -e2


def point_matrix(w: np.ndarray) -> np.ndarray:
    """3x12 matrix x = C q for the 4-vector of weights w = (w_P1, w_P2, w_P3, w_u)."""
    return np.kron(np.asarray(w, float)[None, :], np.eye(3))


def _body_point(abc: np.ndarray) -> np.ndarray:
    return point_matrix([1.0 - abc[0] - abc[1], abc[0], abc[1], abc[2]])


def _body_dir(abc: np.ndarray) -> np.ndarray:
    return point_matrix([-abc[0] - abc[1], abc[0], abc[1], abc[2]])


def _normal(P: np.ndarray) -> np.ndarray:
    c = np.cross(P[1] - P[0], P[2] - P[0])
    return c / np.linalg.norm(c)


def _constants(model: ReferenceModel) -> dict:
    """Everything that is constant in the body: coefficient matrices, lengths, mass matrix."""
    P = np.asarray(model.cp_rest, float)
    u = _normal(P)
    Dinv = np.linalg.inv(np.column_stack([P[1] - P[0], P[2] - P[0], u]))
    g1 = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    g3 = np.cross(g1, u)
    com = np.asarray(model.com_rest, float)
    Ic = np.asarray(model.inertia_rest, float)
    J = 0.5 * np.trace(Ic) * np.eye(3) - Ic
    w_c = np.array([1.0, 0.0, 0.0, 0.0]) + _TM @ Dinv @ (com - P[0])
    W = _TM @ Dinv
    Mhat = model.mass * np.outer(w_c, w_c) + W @ J @ W.T
    p_cl = P[0] + model.A * u - model.B * g3
    return dict(
        L2=np.array([np.sum((P[1] - P[0]) ** 2), np.sum((P[2] - P[0]) ** 2), np.sum((P[2] - P[1]) ** 2)]),
        M=np.kron(Mhat, np.eye(3)),
        C_cm=_body_point(Dinv @ (com - P[0])),
        C_cl=_body_point(Dinv @ (p_cl - P[0])),
        G=[_body_dir(Dinv @ g) for g in (g1, u, g3)],
        p0_cl=p_cl,
        n=np.asarray(model.normals, float),
        tan_phi=np.asarray(model.tan_phi, float),
    )


def _constraints(k: dict, q: np.ndarray, qd: np.ndarray | None = None):
    """Phi (9,), Phi_q (9,12) and, if qd is given, gamma = -(dPhi_q/dt) qd (9,)."""
    P1, P2, P3, u = q.reshape(4, 3)
    d2, d3, d32 = P2 - P1, P3 - P1, P3 - P2
    phi = np.array([k["n"][0] @ P1, k["n"][1] @ P2, k["n"][2] @ P3,
                    d2 @ d2 - k["L2"][0], d3 @ d3 - k["L2"][1], d32 @ d32 - k["L2"][2],
                    u @ u - 1.0, u @ d2, u @ d3])
    J = np.zeros((9, 12))
    for i in range(3):
        J[i, 3 * i:3 * i + 3] = k["n"][i]
    for row, (a, b, d) in zip((3, 4, 5), ((0, 1, d2), (0, 2, d3), (1, 2, d32))):
        J[row, 3 * a:3 * a + 3], J[row, 3 * b:3 * b + 3] = -2 * d, 2 * d
    J[6, 9:12] = 2 * u
    for row, (b, d) in zip((7, 8), ((1, d2), (2, d3))):
        J[row, 0:3], J[row, 3 * b:3 * b + 3], J[row, 9:12] = -u, u, d
    if qd is None:
        return phi, J
    V1, V2, V3, ud = qd.reshape(4, 3)
    e2, e3, e32 = V2 - V1, V3 - V1, V3 - V2
    gamma = -2.0 * np.array([0.0, 0.0, 0.0, e2 @ e2, e3 @ e3, e32 @ e32, ud @ ud, ud @ e2, ud @ e3])
    return phi, J, gamma


def _unit_or(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    nv = np.linalg.norm(v)
    return v / nv if nv >= V_EPS else fallback


def _solve(model: ReferenceModel, k: dict, q: np.ndarray, qd: np.ndarray, dirs: np.ndarray,
           f_ext: np.ndarray, m_ext: np.ndarray, tip_offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Solve eq. 39 (friction moved into the matrix) for qdd (12,) and the multipliers (9,)."""
    _, J, gamma = _constraints(k, q, qd)
    V = qd.reshape(4, 3)
    frames = [G @ q for G in k["G"]]  # g1, g2, g3
    g1 = frames[0]
    # Applied generalized forces: weight, extra force/moment, load and end friction.
    Q = k["C_cm"].T @ (f_ext - model.mass * model.gravity * E2)
    Q += sum(0.5 * G.T @ np.cross(m_ext, g) for G, g in zip(k["G"], frames))
    if model.load_case == "hydrostatic":
        Q += k["C_cl"].T @ (model.force * g1)
    elif model.load_case == "actuator":
        T = k["p0_cl"] + tip_offset * E3
        s = (k["C_cl"] @ q - T) @ g1 / (E1 @ g1)
        P1, P2, P3, u = q.reshape(4, 3)
        abc = np.linalg.solve(np.column_stack([P2 - P1, P3 - P1, u]), T + s * E1 - P1)
        C_L = _body_point(abc)  # the block's material point currently at P_L (eq. 29-30)
        Q += C_L.T @ (model.force * E1)
        if model.tan_phi_ef != 0.0:
            w = C_L @ qd - model.tip_offset_rate * E3
            w_s = w - (w @ g1) / (E1 @ g1) * E1
            f_ef = -model.force * (E1 @ g1) * model.tan_phi_ef * _unit_or(w_s, dirs[3])
            Q += C_L.T @ f_ef
    else:
        raise ValueError(f"unknown load_case {model.load_case!r}")
    # Coulomb friction: lam_i * s_i with s_i = -mu_i v_i/|v_i| in the P_i slot (eq. 21-23, 35); a constant
    # part c_i of the contact's shear strength (the effects' contact law) is an applied force -c_i v_i/|v_i|.
    S = np.zeros((12, 9))
    for i in range(3):
        speed = float(np.linalg.norm(V[i]))
        mu, c = float(k["tan_phi"][i]), 0.0
        for law in model.contact_laws:
            mu, c = law.contact_strength(mu, c, speed)
        d = _unit_or(V[i], dirs[i])
        S[3 * i:3 * i + 3, i] = -mu * d
        Q[3 * i:3 * i + 3] -= c * d
    A = np.block([[k["M"], -(J.T + S)], [J, np.zeros((9, 9))]])
    sol = np.linalg.solve(A, np.concatenate([Q, gamma]))
    return sol[:12], sol[12:]


def _qdot_from(P: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural coordinates (P, u) and their rates from the contact points' positions/velocities."""
    c = np.cross(P[1] - P[0], P[2] - P[0])
    cd = np.cross(V[1] - V[0], P[2] - P[0]) + np.cross(P[1] - P[0], V[2] - V[0])
    u = c / np.linalg.norm(c)
    ud = (cd - u * (u @ cd)) / np.linalg.norm(c)
    return np.concatenate([P.ravel(), u]), np.concatenate([V.ravel(), ud])


def _defaults(rest_directions, extra_force, extra_moment):
    dirs = np.zeros((4, 3)) if rest_directions is None else np.asarray(rest_directions, float)
    f = np.zeros(3) if extra_force is None else np.asarray(extra_force, float)
    m = np.zeros(3) if extra_moment is None else np.asarray(extra_moment, float)
    return dirs, f, m


def reference_accelerations(model: ReferenceModel, P: np.ndarray, V: np.ndarray,
                            rest_directions: np.ndarray | None = None,
                            extra_force: np.ndarray | None = None,
                            extra_moment: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations (3x3, rows CP1..CP3) and normal reactions N (3,), newtons along n_i.

    P, V: positions and velocities of CP1..CP3 (rows) in an admissible state.  rest_directions
    (4x3): unit directions replacing v/|v| when |v| < 1e-12 m/s, rows contacts 1-3 then the tip
    (zeros: no friction there).  extra_force/extra_moment: world frame, at/about the mass centre.
    The tip line is at the model's tip_offset.
    """
    P, V = np.asarray(P, float), np.asarray(V, float)
    q, qd = _qdot_from(P, V)
    qdd, lam = _solve(model, _constants(model), q, qd,
                      *_defaults(rest_directions, extra_force, extra_moment), model.tip_offset)
    return qdd[:9].reshape(3, 3), lam[:3].copy()


def _project(k: dict, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton projection onto Phi(q) = 0, then onto Phi_q qd = 0 (minimum-norm corrections)."""
    for _ in range(20):
        phi, J = _constraints(k, q)
        if np.max(np.abs(phi)) < 1e-14:
            break
        q = q - J.T @ np.linalg.solve(J @ J.T, phi)
    _, J = _constraints(k, q)
    qd = qd - J.T @ np.linalg.solve(J @ J.T, J @ qd)
    return q, qd


def reference_simulate(model: ReferenceModel, t_end: float, dt: float,
                       rest_directions: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Classical RK4 on (q, qdot) from rest at cp_rest, projected onto the constraints each step.

    The step is t_end / round(t_end/dt) (so the last sample is exactly t_end).  The tip offset
    moves as tip_offset + tip_offset_rate * t.  Returns t (n,), P (n,3,3), V (n,3,3).
    """
    k = _constants(model)
    dirs, f0, m0 = _defaults(rest_directions, None, None)
    n_steps = max(1, int(round(t_end / dt)))
    h = t_end / n_steps
    q, qd = _qdot_from(np.asarray(model.cp_rest, float), np.zeros((3, 3)))

    def f(t: float, y: np.ndarray) -> np.ndarray:
        tip = model.tip_offset + model.tip_offset_rate * t
        return np.concatenate([y[12:], _solve(model, k, y[:12], y[12:], dirs, f0, m0, tip)[0]])

    t = np.linspace(0.0, t_end, n_steps + 1)
    Ps, Vs = np.empty((n_steps + 1, 3, 3)), np.empty((n_steps + 1, 3, 3))
    Ps[0], Vs[0] = q[:9].reshape(3, 3), qd[:9].reshape(3, 3)
    y = np.concatenate([q, qd])
    for j in range(n_steps):
        k1 = f(t[j], y)
        k2 = f(t[j] + h / 2, y + h / 2 * k1)
        k3 = f(t[j] + h / 2, y + h / 2 * k2)
        k4 = f(t[j] + h, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        q, qd = _project(k, y[:12], y[12:])
        y = np.concatenate([q, qd])
        Ps[j + 1], Vs[j + 1] = q[:9].reshape(3, 3), qd[:9].reshape(3, 3)
    return t, Ps, Vs
