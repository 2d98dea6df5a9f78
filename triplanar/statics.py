"""Starting and stopping: does friction hold the block, and which way does it start to move?

Coulomb friction at rest is a range, not a value, so neither question is answered by the right-hand
side alone:

* :func:`holds` asks whether *some* static equilibrium exists: normal reactions ``N_i >= 0`` and friction
  forces inside their cones (``|S_i| <= N_i tan(phi_i)`` at each contact, ``|F_EF| <= F_T (e1.g1)
  tan(phi_EF)`` at the tip) that balance the weight and the load, forces and moments. The cones are
  replaced by inscribed 64-gons, a linear program: "holds" is then certain, and a load that the exact
  circles would hold is at most 0.12 % of the friction force away from being called so.
* :func:`incipient_directions` finds, for a block that cannot hold, the directions in which the contact
  points and the aft face start to slip: friction must oppose the incipient slip accelerations, a fixed
  point of the right-hand side.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import linprog

from . import kernel as K
from .model import Model

POLYGON_SIDES = 64
_ANGLES = 2 * math.pi * (np.arange(POLYGON_SIDES) + 0.5) / POLYGON_SIDES
_INSET = math.cos(math.pi / POLYGON_SIDES)


def _equilibrium_lp(model: Model, y: np.ndarray, t: float) -> dict:
    """The static-equilibrium LP at pose ``y`` with the thrust F_T as its last variable.

    Variables: N1..N3, two tangential friction components per contact, two at the tip (if it rubs), F_T.
    Equalities: force and moment balance about the mass centre. Inequalities: inscribed 64-gons of the
    friction cones; the tip's bound F_T (e1.g1) tan(phi_EF) is linear in F_T, so it stays an LP.
    """
    p = model.kernel_params_cached.copy()
    y = y.copy()
    y[K.S_V:K.S_V + 6] = 0.0
    extra_f, extra_m = np.zeros(3), np.zeros(3)
    if model.force_effects:
        state = model.block_state(t, y)
        for effect in model.force_effects:
            f, m = effect.wrench(t, state)
            extra_f += f
            extra_m += m
    rot = np.empty((3, 3))
    K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], rot)
    r = y[K.S_R:K.S_R + 3]
    load_point = r + _load_arm(y, p, rot)
    g1 = rot[:, 0]
    force_dir = np.array([1.0, 0.0, 0.0]) if model.loading.kind == "actuator" else g1
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    normals = model.foundation.normals
    tan_phi = p[K.P_TANPHI:K.P_TANPHI + 3]
    tangents = []
    for i in range(3):  # the same plane bases the kernel uses for a stuck contact
        t1, t2 = np.empty(3), np.empty(3)
        K.tangent_basis(p, i, t1, t2)
        tangents.append((t1, t2))
    directions = [*normals, *(t_ for pair in tangents for t_ in pair)]
    points = [*cps, *np.repeat(cps, 2, axis=0)]
    tip_coefficient = p[K.P_TANEF] * g1[0]  # the tip's friction bound per newton of thrust
    rubs = tip_coefficient > 0
    if rubs:
        directions += [rot[:, 1], rot[:, 2]]
        points += [load_point, load_point]
    directions += [force_dir]
    points += [load_point]
    directions, points = np.array(directions), np.array(points)
    a_eq = np.vstack([directions.T, np.cross(points - r, directions).T])
    weight = np.array([0.0, p[K.P_MASS] * p[K.P_G], 0.0])
    b_eq = -np.concatenate([extra_f - weight, extra_m])
    n_var = len(directions)
    cos_a, sin_a = np.cos(_ANGLES), np.sin(_ANGLES)
    a_ub = np.zeros(((4 if rubs else 3) * POLYGON_SIDES, n_var))
    for i in range(3):
        block = slice(i * POLYGON_SIDES, (i + 1) * POLYGON_SIDES)
        a_ub[block, 3 + 2 * i], a_ub[block, 4 + 2 * i] = cos_a, sin_a
        a_ub[block, i] = -tan_phi[i] * _INSET
    if rubs:
        a_ub[3 * POLYGON_SIDES:, 9], a_ub[3 * POLYGON_SIDES:, 10] = cos_a, sin_a
        a_ub[3 * POLYGON_SIDES:, -1] = -tip_coefficient * _INSET
    bounds = [(0, None)] * 3 + [(None, None)] * (n_var - 4)
    return {"A_eq": a_eq, "b_eq": b_eq, "A_ub": a_ub, "b_ub": np.zeros(len(a_ub)), "bounds": bounds,
            "n_var": n_var}


def _load_arm(y: np.ndarray, p: np.ndarray, rot: np.ndarray) -> np.ndarray:
    arm = np.empty(3)
    K.load_arm(y, p, rot, arm)
    return arm


def holds(model: Model, y: np.ndarray, thrust_N: float | None = None, t: float = 0.0) -> bool:
    """True when a static equilibrium with friction inside its cones exists at pose ``y``.

    ``y``'s velocities are ignored (the block is taken at rest); ``thrust_N`` defaults to the command.
    """
    thrust = model.loading.force_N if thrust_N is None else float(thrust_N)
    lp = _equilibrium_lp(model, y, t)
    res = linprog(np.zeros(lp["n_var"]), A_ub=lp["A_ub"], b_ub=lp["b_ub"], A_eq=lp["A_eq"], b_eq=lp["b_eq"],
                  bounds=lp["bounds"] + [(thrust, thrust)], method="highs")
    return bool(res.status == 0)


def sliding_threshold(model: Model, y: np.ndarray | None = None, upper_N: float | None = None,
                      t: float = 0.0) -> float:
    """The largest thrust (N) that friction can hold at pose ``y`` (default: rest): one LP, maximising F_T.

    The set of thrusts that can be held is an interval (the LP's feasible set is convex), so any larger
    thrust slides. Returns ``inf`` if it still holds at ``upper_N`` (default: 5 x the weight), and ``nan``
    if not even zero thrust can be held (the block slides under its own weight).
    """
    y = model.initial_state() if y is None else y
    upper = upper_N if upper_N is not None else 5.0 * model.specimen.weight_N
    lp = _equilibrium_lp(model, y, t)
    cost = np.zeros(lp["n_var"])
    cost[-1] = -1.0
    res = linprog(cost, A_ub=lp["A_ub"], b_ub=lp["b_ub"], A_eq=lp["A_eq"], b_eq=lp["b_eq"],
                  bounds=lp["bounds"] + [(0.0, upper)], method="highs")
    if res.status != 0:
        return math.nan
    threshold = float(res.x[-1])
    return math.inf if threshold >= upper * (1 - 1e-12) else threshold


def incipient_directions(p: np.ndarray, y: np.ndarray, t: float = 0.0, max_iter: int = 400) -> tuple[bool, float]:
    """Set ``p[P_D0:]`` to the directions in which resting sliding sites begin to slip (see
    :func:`triplanar.kernel.incipient_directions`); returns (converged, consistency)."""
    converged, consistency = K.incipient_directions(t, y, p, max_iter)
    return bool(converged), float(consistency)


def start_motion(p: np.ndarray, y: np.ndarray, t: float = 0.0) -> tuple[bool, float]:
    """Choose how a block that cannot hold starts to move, and set ``p`` for it.

    Tries, in order: all contacts sliding with the tip stuck (if it rubs), all sliding, then one contact
    stuck (a pivot) with the tip stuck or sliding. A mode is accepted when its friction opposes every
    resting site's incipient slip and every stuck site's friction lies inside its cone. Returns
    (accepted, consistency) of the chosen mode; if none is consistent, the most consistent is used.
    """
    rubs = p[K.P_TANEF] > 0 and p[K.P_CASE] == 0
    tip_modes = (1.0, 0.0) if rubs else (0.0,)
    modes = [(-1.0, tip) for tip in tip_modes] + [(float(k), tip) for k in range(3) for tip in tip_modes]
    aux = np.empty(K.N_AUX)
    best = None
    for stuck, tip in modes:
        p[K.P_STUCK], p[K.P_TIP_STUCK] = stuck, tip
        converged, consistency = incipient_directions(p, y, t)
        K.rhs(t, y, p, np.empty(K.N_STATE), aux)
        holds_stuck = aux[K.A_STICK] <= 0.0 and aux[K.A_TIP_STICK] <= 0.0
        score = consistency if holds_stuck else -2.0
        if holds_stuck and consistency > 0.9999:
            return True, consistency
        if best is None or score > best[0]:
            best = (score, stuck, tip)
    p[K.P_STUCK], p[K.P_TIP_STUCK] = best[1], best[2]
    _, consistency = incipient_directions(p, y, t)
    return False, consistency
