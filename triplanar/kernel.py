"""The one right-hand side of the physics, compiled with numba: dynamics, projection, events.

Formulation: Newton-Euler for the rigid block with three Lagrange multipliers, the normal reactions
``N_i`` that hold contact point ``P_i`` on plane ``i`` (the paper's lambda_1..3, eq. 17-20). The paper's
other three multipliers (rigid-frame constraints, eq. 7) are implicit: the block is a rigid body with six
coordinates. Friction ``S_i = -N_i mu_i v_i/|v_i|`` (eq. 21) is proportional to ``N_i``, so at each instant
the three ``N_i`` solve a 3x3 linear system (the analogue of eq. 39). ``docs/physics.md`` derives why this
equals the paper's 9-coordinate Lagrangian; ``triplanar/natural_coordinates.py`` implements that form independently
and the tests compare the two. What advances the state in time (steppers, event location, stick and
slip, start modes) is :mod:`triplanar.stepping`. Mohr-Coulomb cohesion ``c`` (``P_COHESION``, the ``cohesion``
effect; 0 in the paper) adds the known friction part ``-c v_i/|v_i|``, on the right-hand side of that system.

State ``y`` (``N_STATE`` floats): mass-centre position ``r``, unit quaternion ``q`` (w, x, y, z; body to
world, body axes = the paper's g1, g2, g3), velocity ``v``, angular velocity ``omega`` (world axes), actuator
force ``F_T``, lateral tip offset ``u``, then energy integrals: work of the load, dissipation at CP1..3,
dissipation at the tip, work of user forces. Parameters ``p`` (``N_PARAM`` floats) are packed by
:func:`triplanar.model.Model.kernel_params`; their layout is the ``P_*`` constants below.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from numba import njit, objmode

from .compiled_cache import drop_if_stale, numba_cache_dir
from .layout import Layout

# The offsets below are computed by triplanar/layout.py, and numba keys the cache of this file's functions on this
# file only: drop it when the layout code changes.
drop_if_stale(numba_cache_dir(__file__), "kernel.*.nb[ic]", [Path(__file__).parent / "layout.py"],
              "kernel.layout.sha256")

# Compiled with error_model="numpy": a division by zero gives inf/nan (the solvers' isfinite checks catch it) instead
# of raising, which saves a branch per division, ~15 % of a control period; results are bitwise the same.

# -- layouts (triplanar.layout: offsets follow from the sizes; each is unpacked into named integers, e.g. S_V, P_C,
# N_STATE, and the assert after it checks the names against the layout) --
STATE = Layout("S_", "N_STATE", [
    ("R", 3, "mass-centre position r (world), m"),
    ("Q", 4, "unit quaternion (w, x, y, z), body to world; body axes are the paper's g1, g2, g3"),
    ("V", 3, "mass-centre velocity (world), m/s"),
    ("W", 3, "angular velocity omega (world), rad/s"),
    ("F", 1, "actuator force F_T, N"),
    ("U", 1, "lateral tip offset u (+e3), m"),
    ("WLOAD", 1, "work of the load, J"),
    ("DC", 3, "energy dissipated at CP1..3, J"),
    ("DTIP", 1, "energy dissipated at the tip, J"),
    ("WOTHER", 1, "work of user forces, J")])
S_R, S_Q, S_V, S_W, S_F, S_U, S_WLOAD, S_DC, S_DTIP, S_WOTHER, N_STATE = STATE.offsets()
assert STATE.named_in(globals())

PARAMS = Layout("P_", "N_PARAM", [
    ("MASS", 1, "mass, kg"),
    ("G", 1, "gravity, m/s2"),
    ("IB", 9, "inertia about the mass centre, body axes"),
    ("IBINV", 9, "its inverse"),
    ("C", 9, "contact points relative to the mass centre, body axes (row i = CP i+1)"),
    ("N", 9, "plane normals (row i = FP i+1)"),
    ("TANPHI", 3, "tan(phi_i) at the contacts"),
    ("TANEF", 1, "tan(phi_EF) at the tip; 0 = no end friction (case B)"),
    ("CASE", 1, "0: actuator along e1 at the tip line (cases A/B); 1: hydrostatic along g1 at P_CL (case C)"),
    ("FCMD", 1, "commanded thrust F_T, N"),
    ("TAU", 1, "actuator rise time constant, s; 0 = force equals the command"),
    ("PCL", 3, "P_CL relative to the mass centre, body axes"),
    ("TIP0", 3, "P0_CL, the tip line's point at zero offset (world); the line runs along e1"),
    ("UDOT", 1, "lateral tip velocity du/dt, m/s"),
    ("RATE_A", 1, "rate friction: mu = tan(phi) (1 + a ln(1 + |v|/v0))"),
    ("RATE_V0", 1, "its reference slip speed v0, m/s"),
    ("EXTF", 3, "extra force at the mass centre (world), user effects, N"),
    ("EXTM", 3, "extra moment about the mass centre (world), N m"),
    ("USER", 1, "handle of the run's user force function (slow path, user_force), called before each evaluation; 0: none"),
    ("F0", 1, "actuator force when sliding starts (t = 0); with P_TAU > 0 it rises from there to P_FCMD"),
    ("LEFT0", 6, "how far each CP starts across another plane's line (re-seated tilted planes), m"),
    ("COHESION", 1, "Mohr-Coulomb cohesion c at each contact, N: shear strength mu N + c")])
(P_MASS, P_G, P_IB, P_IBINV, P_C, P_N, P_TANPHI, P_TANEF, P_CASE, P_FCMD, P_TAU, P_PCL, P_TIP0, P_UDOT, P_RATE_A,
 P_RATE_V0, P_EXTF, P_EXTM, P_USER, P_F0, P_LEFT0, P_COHESION, N_PARAM) = PARAMS.offsets()
assert PARAMS.named_in(globals())

# -- kernel-level settings ---------------------------------------------------------------------
# Constants of the friction law that effects set by name (``Effect.kernel_settings``, collected in
# ``Model.kernel_settings``); ``Model.kernel_params`` packs each into its slot, or its default when no effect
# sets it, and ``Model.validate`` checks it against its closed range. name: (slot, default, lower, upper).
KERNEL_SETTINGS = {
    "rate_a": (P_RATE_A, 0.0, -math.inf, math.inf),
    "rate_v0_m_s": (P_RATE_V0, 0.05, 1e-12, math.inf),  # must be positive
    "cohesion_N": (P_COHESION, 0.0, 0.0, math.inf),
}

# Stick/slip modes: which site sticks and where a site at rest starts to slip. They change as the block moves (the
# steppers set them at stops and releases, start_motion_ws at a start), so they are kept apart from the parameters
# and the controls (thrust command, stage velocity) in p: a stretch redone starts again from the modes it had. The
# callers keep them in a vector of their own (sliding_modes()); while compiled code runs they sit in a row of the
# workspace (W_MODES, modes_of), where every *_ws function reads and sets them: one more array argument on every
# call below the driver cost ~25 % of a control period (docs/performance.md), the workspace is passed anyway.
MODES = Layout("M_", "N_MODE", [
    ("D0", 12, "friction directions to use at zero slip (rows: CP1..3, tip)"),
    ("STUCK", 1, "index of the contact point that sticks (0-2), or -1: all three slide"),
    ("TIP_STUCK", 1, "1: the aft face sticks to the tip (static end friction), 0: it slips")])
M_D0, M_STUCK, M_TIP_STUCK, N_MODE = MODES.offsets()
assert MODES.named_in(globals())


def sliding_modes() -> np.ndarray:
    """Modes of a block whose contacts all slide and whose tip slips (no direction at rest yet)."""
    modes = np.zeros(N_MODE)
    modes[M_STUCK] = -1.0
    return modes


AUX = Layout("A_", "N_AUX", [  # what dynamics() reports besides the derivative
    ("N", 3, "normal reactions N1..3, N"),
    ("PL", 3, "instantaneous load point (world)"),
    ("ACC", 12, "slip accelerations at CP1..3 and the tip (used to find incipient motion)"),
    ("SLIP", 3, "slip velocity of the aft face relative to the tip"),
    ("FT", 1, "thrust in use, N"),
    ("SPEED", 3, "contact-point speeds, m/s"),
    ("STICK", 1, "stuck contact: |S| - (mu N + c) (> 0: friction cannot hold it any more); -1 otherwise"),
    ("TIP_STICK", 1, "stuck tip: |F_EF| - F_T (e1.g1) tan(phi_EF); -1 otherwise"),
    ("STICK_F", 3, "static friction force on the block at the stuck contact"),
    ("TIP_F", 3, "static end friction force on the block at a stuck tip")])
A_N, A_PL, A_ACC, A_SLIP, A_FT, A_SPEED, A_STICK, A_TIP_STICK, A_STICK_F, A_TIP_F, N_AUX = AUX.offsets()
assert AUX.named_in(globals())

ZERO_SPEED = 1e-9  # m/s: a site slower than this (integration noise) is at rest: its direction is M_D0
# Below SLIP_BLEND a sliding site's friction direction blends from d0 (the direction of incipient motion, or
# of the site's slip at the last step while it was faster than SLIP_BLEND) to the slip direction:
# d = v/SLIP_BLEND + (1 - |v|/SLIP_BLEND) d0. Pure v/|v| makes the slip direction's
# relaxation rate mu N K/|v| (K: contact compliance) unbounded as |v| -> 0, i.e. infinitely stiff just
# after a stick ends. Sticking and holding are decided exactly elsewhere (stick modes, statics), so this
# creates no creep; it shifts a path by about a (SLIP_BLEND/a)^2 ~ 1e-10 m, and the dissipated power is
# computed as f.v, so the energy balance stays exact.
SLIP_BLEND = 1e-5
LEFT_PLANE_TOL = 1e-6  # m: how far below another plane a contact point must be to have crossed onto it

# -- events (event_values): an event has happened where its value is > 0 --------------------------
EVENTS = Layout("EV_", "N_EVENTS", [
    ("TRAVEL", 1, "CP1 reached the travel target"),
    ("LIFT_OFF", 3, "the normal reaction of CP i is negative"),
    ("MC_OUTSIDE", 1, "the mass centre's overhead projection left the contact triangle"),
    ("LEFT_PLANE", 6, "CP i crossed onto plane j (pairs i != j in order)"),
    ("SLOW", 1, "every contact point slower than slow_speed (a candidate arrest)"),
    ("STOP", 3, "CP i slower than slow_speed / 10 (it stops: stick or reverse)"),
    ("RELEASE", 1, "the stuck contact's friction would leave its cone"),
    ("TIP_STOP", 1, "the aft face's slip on the tip slower than slow_speed / 10"),
    ("TIP_RELEASE", 1, "the stuck tip's friction would leave its cone")])
(EV_TRAVEL, EV_LIFT_OFF, EV_MC_OUTSIDE, EV_LEFT_PLANE, EV_SLOW, EV_STOP, EV_RELEASE, EV_TIP_STOP, EV_TIP_RELEASE,
 N_EVENTS) = EVENTS.offsets()
assert EVENTS.named_in(globals())

# -- scratch memory ---------------------------------------------------------------------------
# A right-hand-side evaluation needs ~20 small arrays; allocating them each time (~18 ns each) was half its
# cost. Compiled loops (the driver, the envs) allocate one workspace, a single 2-D array whose rows are scratch
# arrays, and pass it down: one array keeps calls cheap (a tuple of arrays costs a reference count per member per
# call) and row slices are free views. Each module owns its rows: the kernel's come first (below, W_*), then
# triplanar.stepping's (SW_*), then triplanar.driver's (DW_*), then the env's (each layout starts where the one it
# extends ends), and a module's new_workspace() allocates up to its own last row. The public functions without a
# workspace argument allocate their own, for callers outside hot loops. Kernel functions that never run nested
# inside one another share rows (each rewrites what it reads).
WORKSPACE = Layout("W_", "N_KERNEL_WS_ROWS", [
    ("R", 3, "3x3 rotation matrix"),
    ("RHO", 4, "4x3 points of action relative to the mass centre"),
    *((name, 1, "3-vector") for name in ("TMP", "FX", "MX", "IW", "H", "ALPHA0", "ACC", "ALPHA", "MU", "SPEEDS",
                                         "POWER", "WB", "DR", "DTH", "TMP2")),
    ("IINV", 3, "3x3 inverse inertia, world axes"),
    *((name, 7, "7x3") for name in ("FU", "CR", "RXF", "JR", "JTH", "IJT")),
    ("CPS", 3, "3x3 contact points"),
    *((name, 1, "7-vector") for name in ("BIAS", "B", "X", "RESID", "TARGET", "LAM", "AT")),  # AT: indices as floats
    ("MAT", 7, "7x7 matrix"),
    ("COUNT", 1, "counters (zeroed by allocate_workspace): what a run cost and what happened, see C_*"),
    ("MODES", 1, "the stick/slip modes (MODES layout) while compiled code runs: every *_ws function reads and sets "
                 "them here (modes_of)")])
(W_R, W_RHO, W_TMP, W_FX, W_MX, W_IW, W_H, W_ALPHA0, W_ACC, W_ALPHA, W_MU, W_SPEEDS, W_POWER, W_WB, W_DR, W_DTH,
 W_TMP2, W_IINV, W_FU, W_CR, W_RXF, W_JR, W_JTH, W_IJT, W_CPS, W_BIAS, W_B, W_X, W_RESID, W_TARGET, W_LAM, W_AT, W_MAT,
 W_COUNT, W_MODES, N_KERNEL_WS_ROWS) = WORKSPACE.offsets()
assert WORKSPACE.named_in(globals())
# counters in row W_COUNT: right-hand-side evaluations, accepted and rejected steps, events located, rows of the
# event log, starts from rest (mode searches), static-equilibrium checks, stretches redone for the energy balance
C_NFEV, C_NSTEP, C_NREJECT, C_NEVENT, C_NLOG, C_NSTART, C_NLP, C_NREDO = range(8)
WS_WIDTH = max(N_STATE, N_AUX, N_EVENTS, N_MODE, 12)


@njit(cache=True, error_model="numpy")
def allocate_workspace(rows: int) -> np.ndarray:
    """A workspace of ``rows`` rows (a module's ``new_workspace`` passes its own last row), counters at zero, modes
    all sliding (:func:`sliding_modes`)."""
    ws = np.empty((rows, WS_WIDTH))
    ws[W_COUNT, :] = 0.0
    ws[W_MODES, :] = 0.0
    ws[W_MODES, M_STUCK] = -1.0
    return ws


@njit(cache=True, error_model="numpy")
def modes_of(ws: np.ndarray) -> np.ndarray:
    """The stick/slip modes in workspace ``ws`` (a view): whoever keeps the modes between calls (simulate, the envs)
    puts them here before calling a ``*_ws`` function and takes them back after."""
    return ws[W_MODES, :N_MODE]


@njit(cache=True, error_model="numpy")
def new_workspace() -> np.ndarray:
    """Scratch memory for the kernel's own functions (the right-hand side, projection, events)."""
    return allocate_workspace(np.int64(N_KERNEL_WS_ROWS))  # (not a literal: one compiled version for every module)


@njit(cache=True, inline="always", error_model="numpy")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, error_model="numpy")
def quat_to_matrix(q: np.ndarray, out: np.ndarray) -> None:
    w, x, y, z = q[0], q[1], q[2], q[3]
    s = 2.0 / (w * w + x * x + y * y + z * z)
    out[0, 0] = 1 - s * (y * y + z * z); out[0, 1] = s * (x * y - w * z); out[0, 2] = s * (x * z + w * y)
    out[1, 0] = s * (x * y + w * z); out[1, 1] = 1 - s * (x * x + z * z); out[1, 2] = s * (y * z - w * x)
    out[2, 0] = s * (x * z - w * y); out[2, 1] = s * (y * z + w * x); out[2, 2] = 1 - s * (x * x + y * y)


@njit(cache=True, error_model="numpy")
def _solve3(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> bool:
    """Cramer's rule for a 3x3 system; False when singular."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    if det == 0.0 or not math.isfinite(det):
        return False
    inv = 1.0 / det
    out[0] = (b[0] * c00 + a[0, 1] * (a[1, 2] * b[2] - b[1] * a[2, 2]) + a[0, 2] * (b[1] * a[2, 1] - a[1, 1] * b[2])) * inv
    out[1] = (a[0, 0] * (b[1] * a[2, 2] - a[1, 2] * b[2]) + b[0] * c01 + a[0, 2] * (a[1, 0] * b[2] - b[1] * a[2, 0])) * inv
    out[2] = (a[0, 0] * (a[1, 1] * b[2] - b[1] * a[2, 1]) + a[0, 1] * (b[1] * a[2, 0] - a[1, 0] * b[2]) + b[0] * c02) * inv
    return True


@njit(cache=True, error_model="numpy")
def _solve_small(m: np.ndarray, r: np.ndarray, n: int, out: np.ndarray) -> bool:
    """Solve the leading n x n system (n <= 7) by Gaussian elimination with partial pivoting, overwriting
    ``m`` and ``r``; False if singular."""
    if n == 3:
        return _solve3(m, r, out)
    for c in range(n):
        piv = c
        for i in range(c + 1, n):
            if abs(m[i, c]) > abs(m[piv, c]):
                piv = i
        if m[piv, c] == 0.0 or not math.isfinite(m[piv, c]):
            return False
        if piv != c:
            for k in range(n):
                m[c, k], m[piv, k] = m[piv, k], m[c, k]
            r[c], r[piv] = r[piv], r[c]
        for i in range(c + 1, n):
            f = m[i, c] / m[c, c]
            for k in range(c, n):
                m[i, k] -= f * m[c, k]
            r[i] -= f * r[c]
    for i in range(n - 1, -1, -1):
        s = r[i]
        for k in range(i + 1, n):
            s -= m[i, k] * out[k]
        out[i] = s / m[i, i]
    return True


@njit(cache=True, error_model="numpy")
def tangent_basis(p: np.ndarray, j: int, t1: np.ndarray, t2: np.ndarray) -> None:
    """Orthonormal t1, t2 spanning plane j (t2 = n x t1)."""
    n0, n1, n2 = p[P_N + 3 * j], p[P_N + 3 * j + 1], p[P_N + 3 * j + 2]
    if abs(n0) < 0.9:
        a0, a1, a2 = _cross(n0, n1, n2, 1.0, 0.0, 0.0)
    else:
        a0, a1, a2 = _cross(n0, n1, n2, 0.0, 0.0, 1.0)
    nn = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    t1[0], t1[1], t1[2] = a0 / nn, a1 / nn, a2 / nn
    b0, b1, b2 = _cross(n0, n1, n2, t1[0], t1[1], t1[2])
    t2[0], t2[1], t2[2] = b0, b1, b2


@njit(cache=True, error_model="numpy")
def _rotate(R: np.ndarray, p: np.ndarray, k: int, out: np.ndarray) -> None:
    for i in range(3):
        out[i] = R[i, 0] * p[k] + R[i, 1] * p[k + 1] + R[i, 2] * p[k + 2]


@njit(cache=True, error_model="numpy")
def _world_inverse_inertia(R: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """R I_b^-1 R^T."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                for m in range(3):
                    s += R[i, k] * p[P_IBINV + 3 * k + m] * R[j, m]
            out[i, j] = s


@njit(cache=True, error_model="numpy")
def _world_inertia_times(R: np.ndarray, p: np.ndarray, w: np.ndarray, out: np.ndarray, wb: np.ndarray) -> None:
    """(R I_b R^T) w; ``wb`` is scratch."""
    for k in range(3):
        wb[k] = R[0, k] * w[0] + R[1, k] * w[1] + R[2, k] * w[2]
    for i in range(3):
        s = 0.0
        for k in range(3):
            for m in range(3):
                s += R[i, k] * p[P_IB + 3 * k + m] * wb[m]
        out[i] = s


@njit(cache=True, error_model="numpy")
def thrust(t: float, p: np.ndarray) -> float:
    """Actuator force F_T at time t since sliding began: the command, or with a rise time constant tau
    ``F_cmd - (F_cmd - F0) exp(-t/tau)`` in closed form (a stiff ODE for small tau otherwise)."""
    tau = p[P_TAU]
    if tau <= 0.0:
        return p[P_FCMD]
    return p[P_FCMD] - (p[P_FCMD] - p[P_F0]) * math.exp(-t / tau)


@njit(cache=True, inline="always", error_model="numpy")
def _friction_direction(v0, v1, v2, speed, d0, d1, d2):
    """Unit slip direction, blended with the incipient direction (d0, d1, d2) below SLIP_BLEND."""
    if speed >= SLIP_BLEND:
        return v0 / speed, v1 / speed, v2 / speed
    f = 1.0 - speed / SLIP_BLEND
    return v0 / SLIP_BLEND + f * d0, v1 / SLIP_BLEND + f * d1, v2 / SLIP_BLEND + f * d2


@njit(cache=True, error_model="numpy")
def load_arm(y: np.ndarray, p: np.ndarray, R: np.ndarray, out: np.ndarray) -> None:
    """Load point relative to the mass centre: ``P_L`` where the tip line (through P0_CL + u e3, along e1)
    meets the aft face (plane through P_CL with normal g1), paper eq. 27-28; ``P_CL`` for case C."""
    _rotate(R, p, np.int64(P_PCL), out)  # (not a literal: the version the contacts' rows use)
    if p[P_CASE] == 0.0:
        tx = p[P_TIP0] - y[S_R]
        ty = p[P_TIP0 + 1] - y[S_R + 1]
        tz = p[P_TIP0 + 2] + y[S_U] - y[S_R + 2]
        s = ((out[0] - tx) * R[0, 0] + (out[1] - ty) * R[1, 0] + (out[2] - tz) * R[2, 0]) / R[0, 0]
        out[0] = tx + s
        out[1] = ty
        out[2] = tz


@njit(cache=True, error_model="numpy")
def _face_rows(R: np.ndarray, w: np.ndarray, a: int, h: np.ndarray) -> tuple:
    """Row of the tip-stick constraint for face axis g_a (a = 1, 2): the slip component
    sigma_a = (v_B(P_L) - udot e3) . h_a with h_a = g_a - (g_a.e1 / g1.e1) g1, and dh_a/dt."""
    g1x = R[0, 0]
    ga0, ga1, ga2 = R[0, a], R[1, a], R[2, a]
    r = ga0 / g1x
    h[0] = ga0 - r * R[0, 0]; h[1] = ga1 - r * R[1, 0]; h[2] = ga2 - r * R[2, 0]
    dg0, dg1, dg2 = _cross(w[0], w[1], w[2], ga0, ga1, ga2)
    d10, d11, d12 = _cross(w[0], w[1], w[2], R[0, 0], R[1, 0], R[2, 0])
    dr = (dg0 * g1x - ga0 * d10) / (g1x * g1x)
    return (dg0 - dr * R[0, 0] - r * d10, dg1 - dr * R[1, 0] - r * d11, dg2 - dr * R[2, 0] - r * d12)


@njit(cache=True, error_model="numpy")
def dynamics(t: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray, dy: np.ndarray, aux: np.ndarray) -> bool:
    """:func:`dynamics_ws` with its own scratch memory, holding ``modes``."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    return dynamics_ws(t, y, p, dy, aux, ws)


# dynamics_ws in sections. Each section is compiled on its own and inlined into its one caller by LLVM (numba's
# forceinline=True: LLVM's alwaysinline), ahead of numba's pass that removes paired reference counts, which then sees
# the whole. The sections take only the whole arrays (y, p, ws, aux, dy) and scalars, return scalars, and index the
# workspace's rows directly (ws[W_FX, k]), making views only to pass to the kernel's other functions: each view is a
# reference count (an atomic increment and decrement). Measured (docs/performance.md): this form bitwise the same as
# the whole function and 0-5 % faster; the same sections with views of the rows 10 % slower; numba's inline="always"
# (at its own IR level, where each array passed becomes a new reference) 15-20 % slower; plain calls 60 %. Each section
# is a compile of its own (0.1-0.7 CPU-s: benchmarks/compile_profile.py), together about 0.7 s more than the one
# function from an empty cache, which removing duplicate compiled versions elsewhere paid for: the same total as
# before the split within 10 paired rounds (benchmarks/bench_compile.py --ab; docs/performance.md).
@njit(cache=True, forceinline=True, error_model="numpy")
def _points_of_action(y: np.ndarray, p: np.ndarray, ws: np.ndarray, actuator: bool) -> tuple:
    """Rows of ``W_RHO``, relative to the mass centre (world): 0-2 the contacts, 3 the load point. Returns the load's
    direction (e1 for the actuator, g1 for case C) and the material velocity at the load point."""
    R = ws[W_R:W_R + 3, :3]
    tmp = ws[W_TMP, :3]
    for j in range(4):
        if j < 3:
            _rotate(R, p, P_C + 3 * j, tmp)
        else:
            load_arm(y, p, R, tmp)
        ws[W_RHO + j, 0] = tmp[0]; ws[W_RHO + j, 1] = tmp[1]; ws[W_RHO + j, 2] = tmp[2]
    if actuator:
        ld0, ld1, ld2 = 1.0, 0.0, 0.0
    else:
        ld0, ld1, ld2 = ws[W_R, 0], ws[W_R + 1, 0], ws[W_R + 2, 0]
    c0, c1, c2 = _cross(y[S_W], y[S_W + 1], y[S_W + 2], ws[W_RHO + 3, 0], ws[W_RHO + 3, 1], ws[W_RHO + 3, 2])
    return ld0, ld1, ld2, y[S_V] + c0, y[S_V + 1] + c1, y[S_V + 2] + c2


@njit(cache=True, forceinline=True, error_model="numpy")
def _applied_wrench(y: np.ndarray, p: np.ndarray, ws: np.ndarray, F_T: float, ld0: float, ld1: float, ld2: float,
                    vb0: float, vb1: float, vb2: float) -> tuple:
    """Applied force and moment about the mass centre (world) into ``W_FX``, ``W_MX``: weight, thrust along the load's
    direction at the load point, user force and moment. Returns the power of the user wrench and of the load."""
    ws[W_FX, 0] = p[P_EXTF] + F_T * ld0
    ws[W_FX, 1] = p[P_EXTF + 1] + F_T * ld1 - p[P_MASS] * p[P_G]
    ws[W_FX, 2] = p[P_EXTF + 2] + F_T * ld2
    m0, m1, m2 = _cross(ws[W_RHO + 3, 0], ws[W_RHO + 3, 1], ws[W_RHO + 3, 2], F_T * ld0, F_T * ld1, F_T * ld2)
    ws[W_MX, 0] = p[P_EXTM] + m0; ws[W_MX, 1] = p[P_EXTM + 1] + m1; ws[W_MX, 2] = p[P_EXTM + 2] + m2
    p_other = p[P_EXTF] * y[S_V] + p[P_EXTF + 1] * y[S_V + 1] + p[P_EXTF + 2] * y[S_V + 2] \
        + p[P_EXTM] * y[S_W] + p[P_EXTM + 1] * y[S_W + 1] + p[P_EXTM + 2] * y[S_W + 2]
    return p_other, F_T * (ld0 * vb0 + ld1 * vb1 + ld2 * vb2)


@njit(cache=True, forceinline=True, error_model="numpy")
def _end_friction(ws: np.ndarray, aux: np.ndarray, tan_ef: float, tip_stuck: bool, tip_limit: float, p_load: float,
                  wv0: float, wv1: float, wv2: float, vb0: float, vb1: float, vb2: float) -> tuple:
    """Sliding end friction (eq. 32-33 in continuous time). The slip of the face relative to the tip: the tip moves
    along e1 (whatever keeps contact) and laterally at udot, so the slip is ``wv = v_B - udot e3`` projected along e1
    onto the face (into ``aux[A_SLIP]``). A slipping tip's friction is added to ``W_FX``, ``W_MX``. Returns the e1
    speed ``kk`` of that projection, the load's power with the friction's work through the tip's own motion, and the
    power dissipated at the tip."""
    g1x = ws[W_R, 0]
    kk = (wv0 * g1x + wv1 * ws[W_R + 1, 0] + wv2 * ws[W_R + 2, 0]) / g1x
    s0, s1, s2 = wv0 - kk, wv1, wv2
    slip_speed = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    aux[A_SLIP] = s0; aux[A_SLIP + 1] = s1; aux[A_SLIP + 2] = s2
    p_tip = 0.0
    if tan_ef > 0.0 and not tip_stuck:
        d0, d1, d2 = _friction_direction(s0, s1, s2, slip_speed, ws[W_MODES, M_D0 + 9],
                                         ws[W_MODES, M_D0 + 10], ws[W_MODES, M_D0 + 11])
        f0, f1, f2 = -tip_limit * d0, -tip_limit * d1, -tip_limit * d2
        ws[W_FX, 0] += f0; ws[W_FX, 1] += f1; ws[W_FX, 2] += f2
        m0, m1, m2 = _cross(ws[W_RHO + 3, 0], ws[W_RHO + 3, 1], ws[W_RHO + 3, 2], f0, f1, f2)
        ws[W_MX, 0] += m0; ws[W_MX, 1] += m1; ws[W_MX, 2] += m2
        # The friction's work through the tip's own motion (v_B - slip) is delivered by the actuator.
        p_load += f0 * (vb0 - s0) + f1 * (vb1 - s1) + f2 * (vb2 - s2)
        p_tip = tip_limit * (d0 * s0 + d1 * s1 + d2 * s2)
    return kk, p_load, p_tip


@njit(cache=True, forceinline=True, error_model="numpy")
def _gyroscopic(y: np.ndarray, p: np.ndarray, ws: np.ndarray) -> None:
    """I dw/dt = M - w x (I w): the gyroscopic term into ``W_MX``; the world inverse inertia into ``W_IINV``."""
    R = ws[W_R:W_R + 3, :3]
    _world_inertia_times(R, p, y[S_W:S_W + 3], ws[W_IW, :3], ws[W_WB, :3])
    c0, c1, c2 = _cross(y[S_W], y[S_W + 1], y[S_W + 2], ws[W_IW, 0], ws[W_IW, 1], ws[W_IW, 2])
    ws[W_MX, 0] -= c0; ws[W_MX, 1] -= c1; ws[W_MX, 2] -= c2
    _world_inverse_inertia(R, p, ws[W_IINV:W_IINV + 3, :3])


@njit(cache=True, forceinline=True, error_model="numpy")
def _contact_unknowns(y: np.ndarray, p: np.ndarray, ws: np.ndarray, stuck: int) -> None:
    """The normal reactions as the first three unknowns (rows 0-2 of ``W_FU``, ``W_CR``, ``W_AT``): N_j acts along
    f_j = n_j - mu_j d_j while sliding (eq. 21), along n_j when stuck. Each contact's speed, friction coefficient
    (rate friction) and dissipated power per unit friction force d_j . v_j into ``W_SPEEDS``, ``W_MU``, ``W_POWER``.
    Cohesion's constant part -c d_j of the sliding friction is a known force, added to ``W_FX``, ``W_MX``."""
    w0, w1, w2 = y[S_W], y[S_W + 1], y[S_W + 2]
    coh = p[P_COHESION]
    for j in range(3):
        r0, r1, r2 = ws[W_RHO + j, 0], ws[W_RHO + j, 1], ws[W_RHO + j, 2]
        c0, c1, c2 = _cross(w0, w1, w2, r0, r1, r2)
        vj0, vj1, vj2 = y[S_V] + c0, y[S_V + 1] + c1, y[S_V + 2] + c2
        sp = math.sqrt(vj0 * vj0 + vj1 * vj1 + vj2 * vj2)
        ws[W_SPEEDS, j] = sp
        if j == stuck:
            d0, d1, d2 = 0.0, 0.0, 0.0
        else:
            k = M_D0 + 3 * j
            d0, d1, d2 = _friction_direction(vj0, vj1, vj2, sp, ws[W_MODES, k], ws[W_MODES, k + 1],
                                             ws[W_MODES, k + 2])
        ws[W_POWER, j] = d0 * vj0 + d1 * vj1 + d2 * vj2
        mu_j = p[P_TANPHI + j]
        if p[P_RATE_A] != 0.0:
            mu_j *= 1.0 + p[P_RATE_A] * math.log1p(sp / p[P_RATE_V0])
        ws[W_MU, j] = mu_j
        if coh != 0.0 and j != stuck:
            f0, f1, f2 = -coh * d0, -coh * d1, -coh * d2
            ws[W_FX, 0] += f0; ws[W_FX, 1] += f1; ws[W_FX, 2] += f2
            m0, m1, m2 = _cross(r0, r1, r2, f0, f1, f2)
            ws[W_MX, 0] += m0; ws[W_MX, 1] += m1; ws[W_MX, 2] += m2
        n0, n1, n2 = p[P_N + 3 * j], p[P_N + 3 * j + 1], p[P_N + 3 * j + 2]
        ws[W_CR + j, 0] = n0; ws[W_CR + j, 1] = n1; ws[W_CR + j, 2] = n2
        ws[W_FU + j, 0] = n0 - mu_j * d0; ws[W_FU + j, 1] = n1 - mu_j * d1; ws[W_FU + j, 2] = n2 - mu_j * d2
        ws[W_AT, j] = j


@njit(cache=True, forceinline=True, error_model="numpy")
def _static_friction_rows(y: np.ndarray, p: np.ndarray, ws: np.ndarray, stuck: int, tip_stuck: bool,
                          wv0: float, wv1: float, wv2: float) -> int:
    """Unknowns and rows of static friction after the three contacts: the two tangential forces at a stuck contact
    (its slip acceleration in the plane is a constraint), the two face forces at a stuck tip (the face's slip on the
    tip is one, rows from :func:`_face_rows`); then every row's velocity-dependent acceleration into ``W_BIAS``.
    Returns the number of unknowns."""
    w0, w1, w2 = y[S_W], y[S_W + 1], y[S_W + 2]
    nu = 3
    if stuck >= 0:
        cr = ws[W_CR:W_CR + 7, :3]  # rows of this view: the argument type tangent_basis's other callers pass
        tangent_basis(p, stuck, cr[3], cr[4])
        for r in (3, 4):
            ws[W_FU + r, 0] = ws[W_CR + r, 0]; ws[W_FU + r, 1] = ws[W_CR + r, 1]; ws[W_FU + r, 2] = ws[W_CR + r, 2]
            ws[W_AT, r] = stuck
        nu = 5
    i_tip = nu
    if tip_stuck:
        R = ws[W_R:W_R + 3, :3]
        for a in (1, 2):
            dh0, dh1, dh2 = _face_rows(R, y[S_W:S_W + 3], a, ws[W_H, :3])
            ws[W_CR + nu, 0] = ws[W_H, 0]; ws[W_CR + nu, 1] = ws[W_H, 1]; ws[W_CR + nu, 2] = ws[W_H, 2]
            ws[W_FU + nu, 0] = R[0, a]; ws[W_FU + nu, 1] = R[1, a]; ws[W_FU + nu, 2] = R[2, a]
            ws[W_AT, nu] = 3
            ws[W_BIAS, nu] = wv0 * dh0 + wv1 * dh1 + wv2 * dh2
            nu += 1
    for r in range(nu):
        if r < i_tip:
            ws[W_BIAS, r] = 0.0
        i = int(ws[W_AT, r])
        c0, c1, c2 = _cross(w0, w1, w2, ws[W_RHO + i, 0], ws[W_RHO + i, 1], ws[W_RHO + i, 2])
        e0, e1, e2 = _cross(w0, w1, w2, c0, c1, c2)
        ws[W_BIAS, r] += ws[W_CR + r, 0] * e0 + ws[W_CR + r, 1] * e1 + ws[W_CR + r, 2] * e2
    return nu


@njit(cache=True, forceinline=True, error_model="numpy")
def _solve_unknowns(p: np.ndarray, ws: np.ndarray, nu: int) -> bool:
    """The ``nu`` unknowns into ``W_X``, from one small linear system: each row's acceleration, that of the known
    forces (``W_FX``; ``W_MX``, whose angular acceleration goes into ``W_ALPHA0``) plus that of the unknowns (their
    ``I^-1 (rho x f)`` into ``W_RXF``), is zero. False if singular."""
    m = p[P_MASS]
    mx0, mx1, mx2 = ws[W_MX, 0], ws[W_MX, 1], ws[W_MX, 2]
    for k in range(3):
        ws[W_ALPHA0, k] = ws[W_IINV + k, 0] * mx0 + ws[W_IINV + k, 1] * mx1 + ws[W_IINV + k, 2] * mx2
    for u in range(nu):
        j = int(ws[W_AT, u])
        a0, a1, a2 = _cross(ws[W_RHO + j, 0], ws[W_RHO + j, 1], ws[W_RHO + j, 2],
                            ws[W_FU + u, 0], ws[W_FU + u, 1], ws[W_FU + u, 2])
        for k in range(3):
            ws[W_RXF + u, k] = ws[W_IINV + k, 0] * a0 + ws[W_IINV + k, 1] * a1 + ws[W_IINV + k, 2] * a2
    for r in range(nu):
        i = int(ws[W_AT, r])
        n0, n1, n2 = ws[W_CR + r, 0], ws[W_CR + r, 1], ws[W_CR + r, 2]
        rn0, rn1, rn2 = _cross(ws[W_RHO + i, 0], ws[W_RHO + i, 1], ws[W_RHO + i, 2], n0, n1, n2)
        for u in range(nu):
            ws[W_MAT + r, u] = (n0 * ws[W_FU + u, 0] + n1 * ws[W_FU + u, 1] + n2 * ws[W_FU + u, 2]) / m \
                + rn0 * ws[W_RXF + u, 0] + rn1 * ws[W_RXF + u, 1] + rn2 * ws[W_RXF + u, 2]
        ws[W_B, r] = -ws[W_BIAS, r] - (n0 * ws[W_FX, 0] + n1 * ws[W_FX, 1] + n2 * ws[W_FX, 2]) / m \
            - (rn0 * ws[W_ALPHA0, 0] + rn1 * ws[W_ALPHA0, 1] + rn2 * ws[W_ALPHA0, 2])
    return _solve_small(ws[W_MAT:W_MAT + 7, :7], ws[W_B, :7], nu, ws[W_X, :7])


@njit(cache=True, forceinline=True, error_model="numpy")
def _accelerations(p: np.ndarray, ws: np.ndarray, nu: int) -> None:
    """Linear and angular acceleration (``W_ACC``, ``W_ALPHA``) from the known forces and the solved unknowns."""
    m = p[P_MASS]
    for k in range(3):
        ws[W_ACC, k] = ws[W_FX, k] / m
        ws[W_ALPHA, k] = ws[W_ALPHA0, k]
        for u in range(nu):
            ws[W_ACC, k] += ws[W_X, u] * ws[W_FU + u, k] / m
            ws[W_ALPHA, k] += ws[W_X, u] * ws[W_RXF + u, k]


@njit(cache=True, forceinline=True, error_model="numpy")
def _static_friction(p: np.ndarray, aux: np.ndarray, ws: np.ndarray, stuck: int, tip_stuck: bool, nu: int,
                     tip_limit: float, p_load: float, vb0: float, vb1: float, vb2: float) -> float:
    """Static friction at a stuck contact or tip into ``aux``: its force, and how far it is from leaving its cone
    (``A_STICK``, ``A_TIP_STICK``; -1 when nothing sticks). Returns the load's power with the stuck tip's friction,
    which works through the tip's motion (no slip)."""
    aux[A_STICK] = -1.0
    aux[A_TIP_STICK] = -1.0
    for k in range(3):
        aux[A_STICK_F + k] = 0.0
        aux[A_TIP_F + k] = 0.0
    if stuck >= 0:  # its two tangential forces are unknowns 3 and 4
        x3, x4 = ws[W_X, 3], ws[W_X, 4]
        aux[A_STICK] = math.sqrt(x3 ** 2 + x4 ** 2) - ws[W_MU, stuck] * ws[W_X, stuck]
        if p[P_COHESION] != 0.0:
            aux[A_STICK] -= p[P_COHESION]
        for k in range(3):
            aux[A_STICK_F + k] = x3 * ws[W_FU + 3, k] + x4 * ws[W_FU + 4, k]
    if tip_stuck:  # its two face forces are the last two unknowns
        i = nu - 2
        xa, xb = ws[W_X, i], ws[W_X, i + 1]
        aux[A_TIP_STICK] = math.sqrt(xa ** 2 + xb ** 2) - tip_limit
        for k in range(3):
            f = xa * ws[W_FU + i, k] + xb * ws[W_FU + i + 1, k]
            aux[A_TIP_F + k] = f
            p_load += f * (vb0 if k == 0 else (vb1 if k == 1 else vb2))
    return p_load


@njit(cache=True, forceinline=True, error_model="numpy")
def _state_derivative(y: np.ndarray, p: np.ndarray, dy: np.ndarray, ws: np.ndarray, stuck: int, F_T: float,
                      p_load: float, p_tip: float, p_other: float) -> None:
    """dy/dt: kinematics, accelerations, the record of F_T and u, and the rates of the energy integrals."""
    for k in range(3):
        dy[S_R + k] = y[S_V + k]
        dy[S_V + k] = ws[W_ACC, k]
        dy[S_W + k] = ws[W_ALPHA, k]
    w0, w1, w2 = y[S_W], y[S_W + 1], y[S_W + 2]
    qw, qx, qy, qz = y[S_Q], y[S_Q + 1], y[S_Q + 2], y[S_Q + 3]
    dy[S_Q] = 0.5 * (-w0 * qx - w1 * qy - w2 * qz)
    dy[S_Q + 1] = 0.5 * (w0 * qw + w1 * qz - w2 * qy)
    dy[S_Q + 2] = 0.5 * (-w0 * qz + w1 * qw + w2 * qx)
    dy[S_Q + 3] = 0.5 * (w0 * qy - w1 * qx + w2 * qw)
    tau = p[P_TAU]
    dy[S_F] = (p[P_FCMD] - F_T) / tau if tau > 0.0 else 0.0  # the record of F_T; nothing feeds back
    dy[S_U] = p[P_UDOT]
    dy[S_WLOAD] = p_load
    coh = p[P_COHESION]
    for j in range(3):
        dy[S_DC + j] = 0.0 if j == stuck else ws[W_MU, j] * ws[W_X, j] * ws[W_POWER, j]
        if coh != 0.0 and j != stuck:
            dy[S_DC + j] = (ws[W_MU, j] * ws[W_X, j] + coh) * ws[W_POWER, j]
    dy[S_DTIP] = p_tip
    dy[S_WOTHER] = p_other


@njit(cache=True, forceinline=True, error_model="numpy")
def _site_accelerations(y: np.ndarray, aux: np.ndarray, ws: np.ndarray, kk: float,
                        wv0: float, wv1: float, wv2: float) -> None:
    """Into ``aux``: the reactions, the contacts' speeds, the slip accelerations of each site (for incipient motion)
    and the load point."""
    w0, w1, w2 = y[S_W], y[S_W + 1], y[S_W + 2]
    al0, al1, al2 = ws[W_ALPHA, 0], ws[W_ALPHA, 1], ws[W_ALPHA, 2]
    for j in range(4):
        r0, r1, r2 = ws[W_RHO + j, 0], ws[W_RHO + j, 1], ws[W_RHO + j, 2]
        c0, c1, c2 = _cross(al0, al1, al2, r0, r1, r2)
        e0, e1, e2 = _cross(w0, w1, w2, r0, r1, r2)
        e0, e1, e2 = _cross(w0, w1, w2, e0, e1, e2)
        a0, a1, a2 = ws[W_ACC, 0] + c0 + e0, ws[W_ACC, 1] + c1 + e1, ws[W_ACC, 2] + c2 + e2
        if j < 3:
            aux[A_N + j] = ws[W_X, j]
            aux[A_SPEED + j] = ws[W_SPEEDS, j]
            aux[A_ACC + 3 * j] = a0; aux[A_ACC + 3 * j + 1] = a1; aux[A_ACC + 3 * j + 2] = a2
        else:
            # d/dt of the slip when it is zero: (a_B - (a_B . g1 + wv . dg1/dt)/g1x e1) with the tip moving
            # with the face (its e1-speed kk); evaluated where slip ~ 0, which is where it is used.
            g1x, g1y, g1z = ws[W_R, 0], ws[W_R + 1, 0], ws[W_R + 2, 0]
            d10, d11, d12 = _cross(w0, w1, w2, g1x, g1y, g1z)
            k2 = (a0 * g1x + a1 * g1y + a2 * g1z + wv0 * d10 + wv1 * d11 + wv2 * d12 - kk * d10) / g1x
            aux[A_ACC + 9] = a0 - k2; aux[A_ACC + 10] = a1; aux[A_ACC + 11] = a2
    for i in range(3):
        aux[A_PL + i] = y[S_R + i] + ws[W_RHO + 3, i]


@njit(cache=True, error_model="numpy")
def dynamics_ws(t: float, y: np.ndarray, p: np.ndarray, dy: np.ndarray, aux: np.ndarray, ws: np.ndarray) -> bool:
    """Time derivative of the state, and the normal reactions etc. in ``aux``. False if singular.

    Forces (paper section 3.3-3.4, ``docs/physics.md``): weight ``-W e2`` at the mass centre; at each
    contact ``N_i n_i - (N_i mu_i + c) v_i/|v_i|`` (eq. 19-21; ``c``: cohesion, ``P_COHESION``, a known force;
    0 in the paper); cases A/B: thrust ``F_T e1`` at the load point
    ``P_L`` where the tip line meets the aft face (eq. 27-30), and end friction of magnitude
    ``F_T (e1.g1) tan(phi_EF)`` opposing the slip of the aft face relative to the tip (eq. 32-33 in
    continuous time); case C: ``F_T g1`` at the body-fixed ``P_CL``; plus any user force and moment.

    A contact (``modes[M_STUCK]``) or the tip (``modes[M_TIP_STUCK]``) that sticks is held by static friction instead
    its tangential force becomes an unknown and its slip acceleration a constraint row. The unknowns
    (normal reactions, stuck tangential forces) solve one small linear system: the paper's eq. 39 with
    the rigid-frame multipliers eliminated. The sections above do the work, in this order, in the workspace's rows.
    """
    R = ws[W_R:W_R + 3, :3]
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    F_T = thrust(t, p)
    actuator = p[P_CASE] == 0.0
    ld0, ld1, ld2, vb0, vb1, vb2 = _points_of_action(y, p, ws, actuator)
    p_other, p_load = _applied_wrench(y, p, ws, F_T, ld0, ld1, ld2, vb0, vb1, vb2)
    tan_ef = p[P_TANEF] if actuator else 0.0
    tip_stuck = tan_ef > 0.0 and ws[W_MODES, M_TIP_STUCK] != 0.0
    tip_limit = F_T * ws[W_R, 0] * tan_ef
    wv0, wv1, wv2 = vb0, vb1, vb2 - p[P_UDOT]
    kk, p_load, p_tip = _end_friction(ws, aux, tan_ef, tip_stuck, tip_limit, p_load, wv0, wv1, wv2, vb0, vb1, vb2)
    _gyroscopic(y, p, ws)
    stuck = int(ws[W_MODES, M_STUCK])
    _contact_unknowns(y, p, ws, stuck)
    nu = _static_friction_rows(y, p, ws, stuck, tip_stuck, wv0, wv1, wv2)
    if not _solve_unknowns(p, ws, nu):
        return False
    _accelerations(p, ws, nu)
    p_load = _static_friction(p, aux, ws, stuck, tip_stuck, nu, tip_limit, p_load, vb0, vb1, vb2)
    _state_derivative(y, p, dy, ws, stuck, F_T, p_load, p_tip, p_other)
    _site_accelerations(y, aux, ws, kk, wv0, wv1, wv2)
    aux[A_FT] = F_T
    return True


# -- user effects (slow path) ----------------------------------------------------------------
# User-written effects are Python objects, which compiled code cannot hold: numba's nopython mode types no Python
# object, and its first-class function type takes compiled functions only. So a run passes its user force
# function down as a handle in its own parameter vector (``p[P_USER]``, 0: none), which every compiled function
# already gets; :func:`user_force` registers the function under a fresh handle for the duration of the run, and the
# compiled right-hand side calls it through objmode. Each run has its own handle, so runs may overlap (threads,
# nested runs); the cost is one dictionary look-up per call of a path that is already Python.
_USER_FORCES: dict[int, Callable[[float, np.ndarray], tuple]] = {}
_USER_FORCE_HANDLES = itertools.count(1)  # (next() is atomic under the GIL: handles are never shared)


@contextmanager
def user_force(p: np.ndarray, fn: Callable[[float, np.ndarray], tuple] | None) -> Iterator[np.ndarray]:
    """Pass the user force function ``fn`` (``(t, y) -> (force, moment)`` about the mass centre, world axes) to the
    compiled code that runs with parameters ``p`` inside the ``with`` block: ``p[P_USER]`` gets its handle (0 and
    nothing registered when ``fn`` is None). Yields ``p``."""
    if fn is None:
        p[P_USER] = 0.0
        yield p
        return
    handle = next(_USER_FORCE_HANDLES)
    _USER_FORCES[handle] = fn
    p[P_USER] = float(handle)
    try:
        yield p
    finally:
        del _USER_FORCES[handle]


def _call_user_wrench(t: float, y: np.ndarray, p: np.ndarray) -> None:
    force, moment = _USER_FORCES[int(p[P_USER])](t, y)
    p[P_EXTF:P_EXTF + 3] = force
    p[P_EXTM:P_EXTM + 3] = moment


@njit(cache=True, error_model="numpy")
def block_kinematics(y: np.ndarray, p: np.ndarray, R: np.ndarray, cps: np.ndarray, cpv: np.ndarray,
                     load_point: np.ndarray) -> None:
    """What a user effect's state needs, in one compiled call (the slow path calls it at every right-hand-side
    evaluation): rotation ``R`` (3, 3), contact points ``cps`` (3, 3) and their velocities ``cpv`` (v + w x d),
    and the load point (mass centre + :func:`load_arm`)."""
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    tmp = np.empty(3)
    for i in range(3):
        _rotate(R, p, P_C + 3 * i, tmp)
        for k in range(3):
            cps[i, k] = y[S_R + k] + tmp[k]
    w0, w1, w2 = y[S_W], y[S_W + 1], y[S_W + 2]
    for i in range(3):
        d0, d1, d2 = cps[i, 0] - y[S_R], cps[i, 1] - y[S_R + 1], cps[i, 2] - y[S_R + 2]
        cpv[i, 0] = y[S_V] + (w1 * d2 - w2 * d1)
        cpv[i, 1] = y[S_V + 1] + (w2 * d0 - w0 * d2)
        cpv[i, 2] = y[S_V + 2] + (w0 * d1 - w1 * d0)
    load_arm(y, p, R, tmp)
    for k in range(3):
        load_point[k] = y[S_R + k] + tmp[k]


@njit(cache=True, error_model="numpy")
def _user_wrench(t: float, y: np.ndarray, p: np.ndarray) -> None:
    with objmode():
        _call_user_wrench(t, y, p)


@njit(cache=True, error_model="numpy")
def rhs(t: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray, dy: np.ndarray, aux: np.ndarray) -> bool:
    """:func:`rhs_ws` with its own scratch memory, holding ``modes``."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    return rhs_ws(t, y, p, dy, aux, ws)


@njit(cache=True, error_model="numpy")
def rhs_ws(t: float, y: np.ndarray, p: np.ndarray, dy: np.ndarray, aux: np.ndarray,
           ws: np.ndarray) -> bool:
    """The right-hand side every integrator calls: user wrench (if any), then :func:`dynamics`."""
    ws[W_COUNT, C_NFEV] += 1.0
    if p[P_USER] != 0.0:
        _user_wrench(t, y, p)
    return dynamics_ws(t, y, p, dy, aux, ws)


# -- constraint projection ----------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _constraint_rows(y: np.ndarray, p: np.ndarray, jr: np.ndarray, jth: np.ndarray,
                     target: np.ndarray, ws: np.ndarray) -> int:
    """Jacobian rows (d/dr, d/dtheta) of the constraints and their velocity targets: n_i . P_i (rows 0-2);
    a stuck contact's two tangential velocities; a stuck tip's two slip components (velocity level only).
    Returns the number of rows."""
    R = ws[W_R:W_R + 3, :3]
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    rho = ws[W_RHO:W_RHO + 4, :3]
    tmp = ws[W_TMP2, :3]
    for i in range(3):
        _rotate(R, p, P_C + 3 * i, tmp)
        rho[i] = tmp
        for k in range(3):
            jr[i, k] = p[P_N + 3 * i + k]
        target[i] = 0.0
    load_arm(y, p, R, tmp)
    rho[3] = tmp
    at = ws[W_AT, :7]
    at[0], at[1], at[2] = 0, 1, 2
    rows = 3
    stuck = int(ws[W_MODES, M_STUCK])
    if stuck >= 0:
        tangent_basis(p, stuck, jr[3], jr[4])
        at[3], at[4] = stuck, stuck
        target[3], target[4] = 0.0, 0.0
        rows = 5
    if ws[W_MODES, M_TIP_STUCK] != 0.0 and p[P_TANEF] > 0.0 and p[P_CASE] == 0.0:
        w = y[S_W:S_W + 3]
        for a in (1, 2):
            _face_rows(R, w, a, tmp)
            jr[rows] = tmp
            target[rows] = p[P_UDOT] * tmp[2]  # the slip is measured against the moving tip
            at[rows] = 3
            rows += 1
    for i in range(rows):
        c = int(at[i])
        a, b, d = _cross(rho[c, 0], rho[c, 1], rho[c, 2], jr[i, 0], jr[i, 1], jr[i, 2])
        jth[i, 0] = a; jth[i, 1] = b; jth[i, 2] = d
    return rows


@njit(cache=True, error_model="numpy")
def _mass_weighted_correction(y, p, rows, jr, jth, resid, dr, dth, ws: np.ndarray) -> bool:
    """Smallest kinetic-energy-weighted (dr, dtheta) with J (dr, dtheta) = -resid (first ``rows`` rows);
    overwrites ``resid``."""
    m = p[P_MASS]
    R = ws[W_R:W_R + 3, :3]
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    iinv = ws[W_IINV:W_IINV + 3, :3]
    _world_inverse_inertia(R, p, iinv)
    ijt = ws[W_IJT:W_IJT + 7, :3]  # I^-1 (rho_i x n_i), row i
    for i in range(rows):
        for k in range(3):
            ijt[i, k] = iinv[k, 0] * jth[i, 0] + iinv[k, 1] * jth[i, 1] + iinv[k, 2] * jth[i, 2]
    kmat = ws[W_MAT:W_MAT + 7, :7]
    for i in range(rows):
        for j in range(rows):
            kmat[i, j] = (jr[i, 0] * jr[j, 0] + jr[i, 1] * jr[j, 1] + jr[i, 2] * jr[j, 2]) / m \
                + jth[i, 0] * ijt[j, 0] + jth[i, 1] * ijt[j, 1] + jth[i, 2] * ijt[j, 2]
    lam = ws[W_LAM, :7]
    if not _solve_small(kmat, resid, rows, lam):
        return False
    for k in range(3):
        dr[k] = 0.0
        dth[k] = 0.0
        for i in range(rows):
            dr[k] -= lam[i] * jr[i, k] / m
            dth[k] -= lam[i] * ijt[i, k]
    return True


@njit(cache=True, error_model="numpy")
def constraint_residual(y: np.ndarray, p: np.ndarray) -> float:
    """Largest distance (m) of a contact point from its plane."""
    cps = np.empty((3, 3))
    contact_points(y, p, cps)
    worst = 0.0
    for i in range(3):
        g = p[P_N + 3 * i] * cps[i, 0] + p[P_N + 3 * i + 1] * cps[i, 1] + p[P_N + 3 * i + 2] * cps[i, 2]
        worst = max(worst, abs(g))
    return worst


@njit(cache=True, error_model="numpy")
def project(y: np.ndarray, p: np.ndarray, modes: np.ndarray) -> bool:
    """:func:`project_ws` with its own scratch memory, holding ``modes``."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    return project_ws(y, p, ws)


@njit(cache=True, error_model="numpy")
def project_ws(y: np.ndarray, p: np.ndarray, ws: np.ndarray) -> bool:
    """Put the contact points back on their planes and their velocities in the planes, in place.

    Mass-weighted least-squares corrections (the correction of least kinetic energy), Gauss-Newton passes
    until the residual is below 1e-13 m; a stuck contact's velocity is also set to zero. Normalises the
    quaternion.
    """
    qn = math.sqrt(y[S_Q] ** 2 + y[S_Q + 1] ** 2 + y[S_Q + 2] ** 2 + y[S_Q + 3] ** 2)
    for k in range(4):
        y[S_Q + k] /= qn
    jr, jth = ws[W_JR:W_JR + 7, :3], ws[W_JTH:W_JTH + 7, :3]
    resid = ws[W_RESID, :7]
    target = ws[W_TARGET, :7]
    dr = ws[W_DR, :3]
    dth = ws[W_DTH, :3]
    cps = ws[W_CPS:W_CPS + 3, :3]
    for _ in range(6):
        contact_points_ws(y, p, cps, ws)
        worst = 0.0
        for i in range(3):
            g = p[P_N + 3 * i] * cps[i, 0] + p[P_N + 3 * i + 1] * cps[i, 1] + p[P_N + 3 * i + 2] * cps[i, 2]
            resid[i] = g
            worst = max(worst, abs(g))
        if worst < 1e-13:
            break
        _constraint_rows(y, p, jr, jth, target, ws)
        # (np.int64(3), not a literal 3, which numba would compile a second version of the function for)
        if not _mass_weighted_correction(y, p, np.int64(3), jr, jth, resid, dr, dth, ws):
            return False
        for k in range(3):
            y[S_R + k] += dr[k]
        # q <- exp(dth) q, to first order (the correction is tiny), then renormalise.
        qw, qx, qy, qz = y[S_Q], y[S_Q + 1], y[S_Q + 2], y[S_Q + 3]
        y[S_Q] = qw + 0.5 * (-dth[0] * qx - dth[1] * qy - dth[2] * qz)
        y[S_Q + 1] = qx + 0.5 * (dth[0] * qw + dth[1] * qz - dth[2] * qy)
        y[S_Q + 2] = qy + 0.5 * (-dth[0] * qz + dth[1] * qw + dth[2] * qx)
        y[S_Q + 3] = qz + 0.5 * (dth[0] * qy - dth[1] * qx + dth[2] * qw)
        qn = math.sqrt(y[S_Q] ** 2 + y[S_Q + 1] ** 2 + y[S_Q + 2] ** 2 + y[S_Q + 3] ** 2)
        for k in range(4):
            y[S_Q + k] /= qn
    rows = _constraint_rows(y, p, jr, jth, target, ws)
    for i in range(rows):
        resid[i] = jr[i, 0] * y[S_V] + jr[i, 1] * y[S_V + 1] + jr[i, 2] * y[S_V + 2] \
            + jth[i, 0] * y[S_W] + jth[i, 1] * y[S_W + 1] + jth[i, 2] * y[S_W + 2] - target[i]
    if not _mass_weighted_correction(y, p, rows, jr, jth, resid, dr, dth, ws):
        return False
    for k in range(3):
        y[S_V + k] += dr[k]
        y[S_W + k] += dth[k]
    return True


# -- events ----------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def contact_points(y: np.ndarray, p: np.ndarray, out: np.ndarray) -> None:
    """World positions of CP1..CP3 into ``out`` (3, 3)."""
    _contact_points(y, p, out, np.empty((3, 3)), np.empty(3))


@njit(cache=True, error_model="numpy")
def contact_points_ws(y: np.ndarray, p: np.ndarray, out: np.ndarray, ws: np.ndarray) -> None:
    """:func:`contact_points` with scratch from a workspace."""
    _contact_points(y, p, out, ws[W_R:W_R + 3, :3], ws[W_TMP2, :3])


@njit(cache=True, error_model="numpy")
def _contact_points(y: np.ndarray, p: np.ndarray, out: np.ndarray, R: np.ndarray, tmp: np.ndarray) -> None:
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    for i in range(3):
        _rotate(R, p, P_C + 3 * i, tmp)
        for k in range(3):
            out[i, k] = y[S_R + k] + tmp[k]


@njit(cache=True, forceinline=True, error_model="numpy")
def plane_gap(cp: np.ndarray, p: np.ndarray, i: int, j: int, pair: int) -> float:
    """How far (m, in height) contact point ``cp[i]`` is from crossing onto plane ``j`` (``pair``: the pair's index
    0-5 in the order of the left-plane events): its height above plane ``j`` at its horizontal position, less the
    1 um a crossing must reach and the start's re-seating ``P_LEFT0`` (negative: crossed, event 5 + ``pair``)."""
    nj0, nj1, nj2 = p[P_N + 3 * j], p[P_N + 3 * j + 1], p[P_N + 3 * j + 2]
    hj = -(nj0 * cp[i, 0] + nj2 * cp[i, 2]) / nj1
    return cp[i, 1] - hj + LEFT_PLANE_TOL + p[P_LEFT0 + pair]


@njit(cache=True, error_model="numpy")
def crossing_slope(p: np.ndarray, i: int, j: int) -> float:
    """How fast (m of height per m of horizontal distance) plane ``j`` rises above plane ``i`` moving across the line
    where they meet: both planes contain the origin, so the height between them is linear in the horizontal position
    and its gradient's norm turns :func:`plane_gap` into a horizontal distance to that line."""
    ni1, nj1 = p[P_N + 3 * i + 1], p[P_N + 3 * j + 1]
    return math.hypot(p[P_N + 3 * i] / ni1 - p[P_N + 3 * j] / nj1, p[P_N + 3 * i + 2] / ni1 - p[P_N + 3 * j + 2] / nj1)


@njit(cache=True, error_model="numpy")
def event_values(y: np.ndarray, p: np.ndarray, modes: np.ndarray, aux: np.ndarray, x1_target: float, slow_speed: float,
                 out: np.ndarray) -> None:
    """:func:`event_values_ws` with its own scratch memory, holding ``modes``."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    event_values_ws(y, p, aux, x1_target, slow_speed, out, ws)


@njit(cache=True, error_model="numpy")
def event_values_ws(y: np.ndarray, p: np.ndarray, aux: np.ndarray, x1_target: float,
                    slow_speed: float, out: np.ndarray, ws: np.ndarray) -> None:
    """Event functions; an event has happened where its value is > 0 (``aux`` from dynamics at ``y``).

    0: CP1 reached the travel target; 1-3: normal reaction of CP i is negative (lift-off); 4: the mass
    centre's overhead projection left the contact triangle; 5-10: CP i is below another plane j by more
    than 1e-6 m, i.e. crossed the line where the planes meet (the foundation is their upper envelope);
    a point re-seated a hair across a line (tilted planes, ``P_LEFT0``) must go 1 um deeper than it started;
    11: every contact point slower than ``slow_speed`` (a candidate arrest); 12-14: CP i slower than
    ``slow_speed / 10`` (it stops: stick or reverse); 15: the stuck contact's friction would leave its cone;
    16: the aft face's slip on the tip slower than ``slow_speed / 10``; 17: the stuck tip's friction would
    leave its cone.
    """
    cp = ws[W_CPS:W_CPS + 3, :3]
    contact_points_ws(y, p, cp, ws)
    out[0] = cp[0, 0] - x1_target
    for i in range(3):
        out[1 + i] = -aux[A_N + i]
    # Barycentric coordinates of the mass centre in the overhead triangle.
    ax, az = cp[0, 0], cp[0, 2]
    bx, bz = cp[1, 0] - ax, cp[1, 2] - az
    cx, cz = cp[2, 0] - ax, cp[2, 2] - az
    px, pz = y[S_R] - ax, y[S_R + 2] - az
    det = bx * cz - bz * cx
    l1 = (px * cz - pz * cx) / det
    l2 = (bx * pz - bz * px) / det
    out[4] = -min(1.0 - l1 - l2, min(l1, l2))
    k = 5
    for i in range(3):
        for j in range(3):
            if i != j:
                out[k] = -plane_gap(cp, p, i, j, k - 5)
                k += 1
    fastest = max(aux[A_SPEED], max(aux[A_SPEED + 1], aux[A_SPEED + 2]))
    out[EV_SLOW] = slow_speed - fastest
    for i in range(3):
        out[EV_STOP + i] = 0.1 * slow_speed - aux[A_SPEED + i]
    out[EV_RELEASE] = aux[A_STICK]
    rubs = p[P_TANEF] > 0.0 and p[P_CASE] == 0.0 and ws[W_MODES, M_TIP_STUCK] == 0.0
    slip = math.sqrt(aux[A_SLIP] ** 2 + aux[A_SLIP + 1] ** 2 + aux[A_SLIP + 2] ** 2)
    out[EV_TIP_STOP] = 0.1 * slow_speed - slip if rubs else -1.0
    out[EV_TIP_RELEASE] = aux[A_TIP_STICK]


@njit(cache=True, error_model="numpy")
def kinetic_energy_ws(y: np.ndarray, p: np.ndarray, ws: np.ndarray) -> float:
    """The block's kinetic energy at state ``y`` (J), with scratch from a workspace (:func:`new_workspace`)."""
    return _kinetic_energy(y, p, ws[W_R:W_R + 3, :3], ws[W_IW, :3], ws[W_WB, :3])


@njit(cache=True, error_model="numpy")
def _kinetic_energy(y: np.ndarray, p: np.ndarray, R: np.ndarray, iw: np.ndarray, wb: np.ndarray) -> float:
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    _world_inertia_times(R, p, y[S_W:S_W + 3], iw, wb)
    ke = 0.0
    for k in range(3):
        ke += 0.5 * p[P_MASS] * y[S_V + k] ** 2 + 0.5 * y[S_W + k] * iw[k]
    return ke
