"""Does friction hold the block at rest? The static-equilibrium LP, compiled, in generator form.

Formulation. The block is at rest if some set of contact forces balances the weight, the thrust and any
external wrench (forces, and moments about the mass centre), with each contact force inside its friction cone.
The cones are replaced by the same inscribed 64-gons as before (a "holds" answer is certain; near the exact
threshold it is conservative by at most 1 - cos(pi/64) = 0.12 % of the friction force), but written by their
*generators* instead of their faces: every force in the polygonal cone at contact ``i`` is a non-negative
combination of the 64 edge rays

    n_i + tan(phi_i) (cos th_k t1_i + sin th_k t2_i),    th_k = 2 pi k / 64,

(unit normal component, so ``N_i`` is the sum of their weights). These rays are the vertices of the regular
64-gon of radius ``tan(phi_i)``, whose faces lie at angles ``(k + 1/2) 2 pi/64`` at distance
``tan(phi_i) cos(pi/64)``: exactly the face form's polygon. The tip is the same with the thrust in place of
the normal: if it rubs (``tan(phi_EF) (e1.g1) > 0``), 64 rays ``d + tan(phi_EF) (e1.g1) (cos th_k g2 +
sin th_k g3)`` at the load point, and ``F_T`` is the sum of their weights; otherwise the single ray ``d``.
The thrust direction ``d`` is ``e1`` for the actuator and ``g1`` for the hydrostatic load (case C).

The LP is then tiny: six equality rows (force and moment balance about the mass centre; the moment rows are
divided by the block's size, the longest contact-point arm, so that all rows have entries of order one, and
the right-hand side by the weight, so that it is of order one too) and 256 or 193 non-negative columns.
``holds`` adds the row ``sum(tip weights) = F_T`` and asks whether the LP is feasible; ``max_thrust``
maximises ``sum(tip weights)`` with ``sum(tip weights) + s = upper`` as a seventh row.

Why a hand-written simplex (:func:`simplex`): the answer is needed inside compiled code (the Gymnasium env
decides arrests inside numba), and scipy's HiGHS costs ~1.5 ms per call, mostly Python overhead. quantecon's
``linprog_simplex`` is numba-compiled too, but importing quantecon takes ~2.8 s and pulls in sympy. A dense
two-phase tableau on 7 rows is a few tens of microseconds.

numba keys its on-disk cache on this file only, while the functions here compile the kernel's helpers and
``P_*`` constants in; :func:`triplanar.compiled_cache.drop_if_stale` discards this module's cache when the
kernel changes.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numba import njit

from . import kernel as K
from .compiled_cache import drop_if_stale, numba_cache_dir
from .kernel import (P_C, P_CASE, P_G, P_MASS, P_N, P_TANEF, P_TANPHI, S_Q, S_R, contact_points, load_arm,
                     quat_to_matrix, tangent_basis)

POLYGON_SIDES = 64
N_CONTACT_COLUMNS = 3 * POLYGON_SIDES

# simplex status codes
OPTIMAL, INFEASIBLE, UNBOUNDED, ITERATION_LIMIT = 0, 1, 2, 3
MAX_ITER = 5000          # pivots over both phases; the contact LP needs ~10-40
BLAND_AFTER = 20         # consecutive degenerate pivots before Bland's rule takes over (until progress resumes)
PIVOT_TOL = 1e-9         # smallest usable pivot in a row-equilibrated tableau (rows start with max |entry| = 1)
OPTIMALITY_TOL = 1e-10   # reduced costs, relative to the largest cost of the phase
FEASIBILITY_TOL = 1e-9   # phase-1 residual, relative to max(1, largest |b| of the equilibrated rows)

drop_if_stale(numba_cache_dir(__file__), "equilibrium.*.nb[ic]", [Path(K.__file__)],
              "equilibrium.kernel.sha256")


# -- a small dense simplex ------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _pivot(t: np.ndarray, basis: np.ndarray, r: int, s: int) -> None:
    """Pivot the tableau on row r, column s (all rows, both objective rows and the right-hand side)."""
    rows, width = t.shape
    inv = 1.0 / t[r, s]
    for j in range(width):
        t[r, j] *= inv
    t[r, s] = 1.0
    for i in range(rows):
        if i == r:
            continue
        f = t[i, s]
        if f == 0.0:
            continue
        for j in range(width):
            t[i, j] -= f * t[r, j]
        t[i, s] = 0.0
    basis[r] = s


@njit(cache=True, error_model="numpy")
def _iterate(t: np.ndarray, basis: np.ndarray, n: int, obj: int, opt_tol: float, max_iter: int,
             bland_after: int, done: int) -> tuple:
    """Simplex pivots on objective row ``obj`` with columns 0..n-1 eligible to enter, until optimal (0),
    unbounded (2) or ``max_iter`` pivots in all (3). Returns (status, pivots done so far)."""
    m = basis.shape[0]
    rhs = t.shape[1] - 1
    degenerate = 0
    while True:
        bland = degenerate >= bland_after
        s = -1
        best = -opt_tol
        for j in range(n):  # Dantzig: most negative reduced cost; Bland: the first negative one
            d = t[obj, j]
            if d < best:
                s = j
                if bland:
                    break
                best = d
        if s < 0:
            return OPTIMAL, done
        if done >= max_iter:
            return ITERATION_LIMIT, done
        theta = math.inf
        for i in range(m):
            a = t[i, s]
            if a > PIVOT_TOL:
                ratio = max(t[i, rhs], 0.0) / a
                if ratio < theta:
                    theta = ratio
        if theta == math.inf:
            return UNBOUNDED, done
        # among rows within rounding of the minimum ratio: the largest pivot (stable), or under Bland's rule
        # the smallest basic index (which is what makes it finite)
        limit = theta + 1e-12 * (1.0 + theta)
        r = -1
        for i in range(m):
            a = t[i, s]
            if a > PIVOT_TOL and max(t[i, rhs], 0.0) / a <= limit:
                if r < 0 or (basis[i] < basis[r] if bland else a > t[r, s]):
                    r = i
        degenerate = degenerate + 1 if theta <= PIVOT_TOL else 0
        _pivot(t, basis, r, s)
        done += 1


@njit(cache=True, error_model="numpy")
def simplex(a: np.ndarray, b: np.ndarray, c: np.ndarray, x: np.ndarray, max_iter: int = MAX_ITER,
            bland_after: int = BLAND_AFTER) -> tuple:
    """Minimise ``c.x`` subject to ``a x = b``, ``x >= 0`` (``a`` is m x n); the solution goes into ``x``.

    Two-phase dense tableau: rows with negative ``b`` are flipped and every row is divided by its largest
    coefficient (tolerances are then relative to the row scales); phase 1 minimises the sum of one artificial
    per row, artificials left basic at zero are pivoted out (or their row dropped as redundant), phase 2
    minimises ``c.x``. Entering column: Dantzig's most negative reduced cost, switching to Bland's rule after
    ``bland_after`` consecutive degenerate pivots (0: always Bland) until a pivot makes progress, so it cannot
    cycle. Returns (status, objective): status 0 optimal, 1 infeasible (objective nan), 2 unbounded (-inf),
    3 iteration limit (nan); ``x`` holds the last basic solution.
    """
    m, n = a.shape
    width = n + m + 1
    rhs = width - 1
    t = np.zeros((m + 2, width))  # rows 0..m-1: constraints; m: phase-2 reduced costs; m+1: phase-1
    basis = np.empty(m, np.int64)
    b_scale = 1.0
    for i in range(m):
        scale = 0.0
        for j in range(n):
            scale = max(scale, abs(a[i, j]))
        if scale == 0.0:
            scale = 1.0  # an empty row: feasible only if b_i = 0, which phase 1 decides
        f = (-1.0 if b[i] < 0.0 else 1.0) / scale
        for j in range(n):
            t[i, j] = a[i, j] * f
        t[i, n + i] = 1.0
        t[i, rhs] = b[i] * f
        b_scale = max(b_scale, abs(t[i, rhs]))
        basis[i] = n + i
    c_scale = 0.0
    for j in range(n):
        t[m, j] = c[j]
        c_scale = max(c_scale, abs(c[j]))
    w_scale = 0.0
    for j in range(n):
        s = 0.0
        for i in range(m):
            s += t[i, j]
        t[m + 1, j] = -s
        w_scale = max(w_scale, abs(s))
    s = 0.0
    for i in range(m):
        s += t[i, rhs]
    t[m + 1, rhs] = -s

    x[:] = 0.0
    status, done = _iterate(t, basis, n, m + 1, OPTIMALITY_TOL * max(w_scale, 1e-300), max_iter, bland_after, 0)
    if status == ITERATION_LIMIT:
        for i in range(m):
            if basis[i] < n:
                x[basis[i]] = t[i, rhs]
        return ITERATION_LIMIT, math.nan
    residual = 0.0
    for i in range(m):
        if basis[i] >= n:
            residual += max(t[i, rhs], 0.0)
    if residual > FEASIBILITY_TOL * b_scale:
        return INFEASIBLE, math.nan
    for i in range(m):  # artificials still basic (at zero): pivot them out, or drop their (redundant) row
        if basis[i] < n:
            continue
        best, s_best = PIVOT_TOL, -1
        for j in range(n):
            if abs(t[i, j]) > best:
                best, s_best = abs(t[i, j]), j
        t[i, rhs] = 0.0
        if s_best >= 0:
            _pivot(t, basis, i, s_best)
        else:
            for j in range(n):
                t[i, j] = 0.0

    status, done = _iterate(t, basis, n, m, OPTIMALITY_TOL * max(c_scale, 1e-300), max_iter, bland_after, done)
    for i in range(m):
        if basis[i] < n:
            x[basis[i]] = max(t[i, rhs], 0.0)
    if status == UNBOUNDED:
        return UNBOUNDED, -math.inf
    if status == ITERATION_LIMIT:
        return ITERATION_LIMIT, math.nan
    objective = 0.0
    for j in range(n):
        objective += c[j] * x[j]
    return OPTIMAL, objective


# -- the static-equilibrium LP --------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def equilibrium_system(y: np.ndarray, p: np.ndarray, ext_f: np.ndarray, ext_m: np.ndarray,
                       extra_rows: int, extra_columns: int) -> tuple:
    """The generator-form balance ``a x = b`` at pose ``y`` (velocities ignored) with ``extra_rows`` zero rows
    and ``extra_columns`` zero columns appended for the caller.

    Columns: 64 per contact (CP1..CP3), then the tip's 64 (or 1 if it does not rub), then the extras. Rows:
    force balance / weight, moment balance about the mass centre / (weight x size). ``ext_f``, ``ext_m``:
    external force at the mass centre and moment about it (world axes). Returns (a, b, first tip column,
    number of tip columns, weight): the tip columns' weights sum to ``F_T / weight``.
    """
    rot = np.empty((3, 3))
    quat_to_matrix(y[S_Q:S_Q + 4], rot)
    arm = np.empty(3)
    load_arm(y, p, rot, arm)
    cps = np.empty((3, 3))
    contact_points(y, p, cps)
    tip_coef = p[P_TANEF] * rot[0, 0]  # the tip's friction bound per newton of thrust
    n_tip = POLYGON_SIDES if tip_coef > 0.0 else 1
    rows = 6 + extra_rows
    a = np.zeros((rows, N_CONTACT_COLUMNS + n_tip + extra_columns))
    b = np.zeros(rows)
    size = 0.0
    for i in range(3):
        size = max(size, math.sqrt(p[P_C + 3 * i] ** 2 + p[P_C + 3 * i + 1] ** 2 + p[P_C + 3 * i + 2] ** 2))
    if size == 0.0:
        size = 1.0
    weight = p[P_MASS] * p[P_G]
    if not weight > 0.0:
        weight = 1.0
    cos_k = np.empty(POLYGON_SIDES)
    sin_k = np.empty(POLYGON_SIDES)
    for k in range(POLYGON_SIDES):
        cos_k[k] = math.cos(2.0 * math.pi * k / POLYGON_SIDES)
        sin_k[k] = math.sin(2.0 * math.pi * k / POLYGON_SIDES)
    t1 = np.empty(3)
    t2 = np.empty(3)
    d = np.empty(3)
    r = np.empty(3)
    for i in range(4):
        if i < 3:  # contact i: normal plus friction in the plane basis the kernel uses for a stuck contact
            tangent_basis(p, i, t1, t2)
            coef = p[P_TANPHI + i]
            for k in range(3):
                d[k] = p[P_N + 3 * i + k]
                r[k] = cps[i, k] - y[S_R + k]
            first, count = i * POLYGON_SIDES, POLYGON_SIDES
        else:  # the thrust, plus end friction in the aft face (g2, g3) if the tip rubs
            for k in range(3):
                t1[k], t2[k] = rot[k, 1], rot[k, 2]
                d[k] = rot[k, 0] if p[P_CASE] != 0.0 else (1.0 if k == 0 else 0.0)
                r[k] = arm[k]
            coef = tip_coef if n_tip > 1 else 0.0
            first, count = N_CONTACT_COLUMNS, n_tip
        for k in range(count):
            f0 = d[0] + coef * (cos_k[k] * t1[0] + sin_k[k] * t2[0])
            f1 = d[1] + coef * (cos_k[k] * t1[1] + sin_k[k] * t2[1])
            f2 = d[2] + coef * (cos_k[k] * t1[2] + sin_k[k] * t2[2])
            j = first + k
            a[0, j], a[1, j], a[2, j] = f0, f1, f2
            a[3, j] = (r[1] * f2 - r[2] * f1) / size
            a[4, j] = (r[2] * f0 - r[0] * f2) / size
            a[5, j] = (r[0] * f1 - r[1] * f0) / size
    # the reactions carry the weight (m g along -e2, at the mass centre) and the external wrench
    for k in range(3):
        b[k] = -ext_f[k] / weight
        b[3 + k] = -ext_m[k] / (weight * size)
    b[1] += 1.0
    return a, b, N_CONTACT_COLUMNS, n_tip, weight


@njit(cache=True, error_model="numpy")
def holds(y: np.ndarray, p: np.ndarray, thrust: float, ext_f: np.ndarray, ext_m: np.ndarray) -> bool:
    """True when friction can hold the block at rest at pose ``y`` under ``thrust`` (N, >= 0; the thrust is a
    push, so a negative one is never held) and the external force ``ext_f`` / moment ``ext_m`` (world axes,
    about the mass centre). Feasibility of the generator LP plus the row ``sum(tip weights) = thrust``."""
    a, b, first, n_tip, weight = equilibrium_system(y, p, ext_f, ext_m, 1, 0)
    for j in range(first, first + n_tip):
        a[6, j] = 1.0
    b[6] = thrust / weight
    x = np.empty(a.shape[1])
    status, _ = simplex(a, b, np.zeros(a.shape[1]), x, MAX_ITER, BLAND_AFTER)
    if status == ITERATION_LIMIT:
        raise RuntimeError("equilibrium.holds: simplex iteration limit")
    return status == OPTIMAL


@njit(cache=True, error_model="numpy")
def max_thrust(y: np.ndarray, p: np.ndarray, upper: float, ext_f: np.ndarray, ext_m: np.ndarray) -> float:
    """The largest thrust (N) friction can hold at pose ``y`` with the external wrench (``ext_f``, ``ext_m``).

    ``inf`` if it holds at ``upper`` (within 1e-12 relative; an infinite ``upper`` adds no row and an unbounded
    LP gives ``inf``), ``nan`` if not even zero thrust is held. The held thrusts form an interval from zero
    (the feasible set is convex and contains the zero-thrust solution), so every larger thrust slides.
    """
    bounded = math.isfinite(upper)
    a, b, first, n_tip, weight = equilibrium_system(y, p, ext_f, ext_m, 1 if bounded else 0, 1 if bounded else 0)
    n = a.shape[1]
    c = np.zeros(n)
    for j in range(first, first + n_tip):
        c[j] = -1.0
    if bounded:
        for j in range(first, first + n_tip):
            a[6, j] = 1.0
        a[6, n - 1] = 1.0  # the slack: sum(tip weights) + s = upper
        b[6] = upper / weight
    x = np.empty(n)
    status, objective = simplex(a, b, c, x, MAX_ITER, BLAND_AFTER)
    if status == INFEASIBLE:
        return math.nan
    if status == UNBOUNDED:
        return math.inf
    if status == ITERATION_LIMIT:
        raise RuntimeError("equilibrium.max_thrust: simplex iteration limit")
    threshold = -objective * weight
    return math.inf if threshold >= upper * (1 - 1e-12) else threshold
