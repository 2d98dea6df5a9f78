"""Prediction with the env's own compiled step, for the model-based controllers (:mod:`agents.limit`,
:mod:`agents.mpc`): a bench's state (block, bench servos, latency queue, bookkeeping) copied out of a
``TriPlanarShear-v1`` env (:func:`snapshot`), one bench period from such a state (:func:`step_state`: exactly what
:meth:`envs.triplanar_shear_v1.TriPlanarShearV1Env.step` runs, the compiled bench command
:func:`envs.triplanar_shear_v1.bench_command` then the control step :func:`envs.core.control_step`), and batched
rollouts of candidate action sequences scored by the episode's metric (:func:`rollout_costs`, :func:`predict`). A
prediction from the env's true state is the env's future to the last bit (``tests/agents/test_mpc.py``); there is
no second physics. It lives with the env because it is the env's compiled step: the env's stale-cache check covers
it, and :func:`triplanar.warmup.warm_envs` compiles it with the env's other kernels (:func:`warm_up`).

**Cost of a candidate** (mm m, the numerator of the episode's mimicry error, ``docs/environment.md``): the
travel-integrated distance to the reference so far, plus the distance at the horizon's end times the travel still
to go (the deviation left at the horizon is assumed to persist: a cost-to-go that does not reward moving slowly),
plus ``cfg[CF_FAIL] * travel`` for a candidate that ends the test other than by reaching the travel target or runs
into the time limit (the score counts a failure as 10 mm; this is 50 mm by default: failures are avoided first),
plus ``cfg[CF_FAIL]`` times the travel by which the block lags a pace of the whole travel in ``pace_s`` at the
horizon's end (without it a short horizon lets the block creep: creeping costs nothing within the horizon, and
the time limit or an arrest lies beyond it).

**Safety margin** (optional, zero by default). A controller can ask a candidate to keep its distance from lift-off
(``triplanar.outcome``): ``mpc``, whose hypotheses are not the bench, and ``limit``, whose search does not see past
its horizon, both ask for 0.1 of the normal load. Each period the smallest normal reaction is compared with
``normal_margin`` times the normal load, and the deepest intrusion into that margin over the horizon, as a fraction of
the margin (0-1), adds that fraction of the failure penalty. A graded penalty rather than a hard one, so that a plan
that starts inside the margin still has a direction out of it.

**Plane margin** (optional, zero by default): the same for leaving a plane (``plane_margin``, m). The kernel's
left-plane event is a height: a contact point's height above a neighbouring plane. Both planes contain the origin, so
that height is linear in the point's horizontal position, and divided by the norm of its gradient
(:func:`triplanar.kernel.crossing_slope`) it is the horizontal distance to the line where the planes meet. Each period
the depth into the margin (0-1, the closest point and line) is taken, and its mean over the horizon, times the failure
penalty, is added. A mean rather than the deepest value: CP3 starts where the three planes meet, inside any margin, so
the deepest value would be the same for every candidate early on; the mean rewards moving out. (In height the margin
could not be set: at rest a contact point sits within 10 um of a neighbouring plane, and 10 um of height is 0.04 mm of
distance from the FP2/FP3 line but 0.6 mm from a line between planes whose dips differ by 1 deg.)

**Work budget** (optional, zero by default: none). A period costs the kernel 10-70 right-hand-side evaluations
where the block slides or sticks cleanly, and thousands where a candidate's commands bring it to a stiff regime
(a contact slipping slowly at the edge of sticking: on a tuning bench, 6,800 evaluations and 5 ms of CPU per period
against 13 and 0.01 ms), which makes a planner's decision cost unbounded. With ``fev_budget`` a candidate's rollout
ends after the period in which its evaluations exceed the budget, and is scored as if its horizon ended there (the
cost so far plus the distance then times the travel still to go, and the pace term): a shorter look-ahead for that
candidate, not a failure. Counted in evaluations, not seconds, so that a prediction is the same on every machine.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
from numba import njit

from triplanar import kernel as K
from triplanar.outcome import RUNNING, TIME_LIMIT, TRAVEL

from .core import (
    CF_FAIL,
    CF_TRAVEL,
    EW_AUX,
    EW_DY,
    IN_DIST,
    IN_TRAVEL,
    IN_TRUNC,
    N_INFO,
    OBS_DIM,
    ST_ERR_NUM,
    ST_LOAD,
    ST_T,
    control_step,
    new_workspace,
)
from .triplanar_shear_v1 import BenchState, bench_command

__all__ = ["BENCH_STATE_FIELDS", "BenchState", "crossing_slopes", "margin_intrusion", "plane_intrusion", "predict",
           "rollout_costs", "snapshot", "step_state", "warm_up"]


BENCH_STATE_FIELDS = tuple(f.name for f in fields(BenchState))


def snapshot(env) -> BenchState:
    """The exact state of a reset ``TriPlanarShearV1Env`` (its :meth:`~envs.triplanar_shear_v1.TriPlanarShearV1Env.get_state`;
    wrappers are looked through): what the limit controller knows."""
    return env.unwrapped.get_state()


@njit(cache=True, error_model="numpy")
def step_state(y, p, modes, armed, st, ref, cfg, bc, bs, queue, raw, applied, obs, inf, ws) -> int:
    """One bench period from the given state (the env's ``step`` without the Python bookkeeping); returns the
    outcome code (``inf[IN_TRUNC]`` flags the time limit)."""
    bench_command(raw, bc, bs, queue, y, st, applied)
    return control_step(y, p, modes, armed, st, ref, applied, cfg, obs, inf, ws)


@njit(cache=True, error_model="numpy")
def margin_intrusion(y, p, st, normal_margin, ws) -> float:
    """How deep the block is into the normal-reaction margin (module docstring), as a fraction 0-1 of it."""
    aux, dy = ws[EW_AUX, :K.N_AUX], ws[EW_DY, :K.N_STATE]
    K.rhs_ws(st[ST_T], y, p, dy, aux, ws)
    limit = normal_margin * st[ST_LOAD]
    worst = 0.0
    for i in range(3):
        worst = max(worst, (limit - aux[K.A_N + i]) / limit)
    return min(worst, 1.0)


@njit(cache=True, error_model="numpy")
def crossing_slopes(p) -> np.ndarray:
    """:func:`triplanar.kernel.crossing_slope` of the six (contact point, other plane) pairs in the order of the
    left-plane events: the planes are fixed within a rollout, so they are computed once per batch."""
    slopes, pair = np.empty(6), 0
    for i in range(3):
        for j in range(3):
            if i != j:
                slopes[pair] = K.crossing_slope(p, i, j)
                pair += 1
    return slopes


@njit(cache=True, error_model="numpy")
def plane_intrusion(y, p, plane_margin, slopes, cp, ws) -> float:
    """How deep a contact point is into the plane margin (module docstring), as a fraction 0-1 of it (``slopes``:
    :func:`crossing_slopes` of ``p``; ``cp``: scratch for the contact points)."""
    K.contact_points_ws(y, p, cp, ws)
    worst, pair = 0.0, 0
    for i in range(3):
        for j in range(3):
            if i != j:
                if slopes[pair] > 0.0:
                    distance = K.plane_gap(cp, p, i, j, pair) / slopes[pair]
                    worst = max(worst, (plane_margin - distance) / plane_margin)
                pair += 1
    return min(worst, 1.0)


@njit(cache=True, error_model="numpy")
def rollout_costs(y0, p0, modes0, armed0, st0, ref, cfg, bc, bs0, queue0, plans, pace_s, costs, dists,
                  codes, fevs, normal_margin=0.0, plane_margin=0.0, fev_budget=0.0) -> None:
    """Run every candidate ``plans[i]`` (horizon x 2 raw actions) from the given state; write its cost (module
    docstring) into ``costs[i]``, the distance after each period (mm) into ``dists[i]`` and the outcome of each
    period into ``codes[i]`` (-1 after the end; ``TIME_LIMIT`` for a truncation), its right-hand-side evaluations into
    ``fevs[i]`` (the kernel's work). A positive ``fev_budget`` ends a candidate's rollout after the period in which
    its evaluations exceed it, scored as at its horizon's end (module docstring, "Work budget")."""
    n, horizon = plans.shape[0], plans.shape[1]
    ws = new_workspace()
    applied, obs, inf = np.zeros(2), np.zeros(OBS_DIM), np.zeros(N_INFO)
    guarded, plane_guarded = normal_margin > 0.0, plane_margin > 0.0
    cp, slopes = np.empty((3, 3)), crossing_slopes(p0)
    travel = cfg[CF_TRAVEL]
    for i in range(n):
        y, p, modes, armed, st = y0.copy(), p0.copy(), modes0.copy(), armed0.copy(), st0.copy()
        bs, queue = bs0.copy(), queue0.copy()
        failed = False
        fev0 = ws[K.W_COUNT, K.C_NFEV]
        dist, s, intrusion, plane_sum = 0.0, 0.0, 0.0, 0.0
        for k in range(horizon):
            codes[i, k] = -1
            dists[i, k] = np.nan
        for k in range(horizon):
            code = step_state(y, p, modes, armed, st, ref, cfg, bc, bs, queue, plans[i, k], applied, obs, inf, ws)
            dist, s = inf[IN_DIST], inf[IN_TRAVEL]
            dists[i, k] = dist
            codes[i, k] = code
            if inf[IN_TRUNC] != 0.0:
                codes[i, k] = TIME_LIMIT
                failed = True
                break
            if code != RUNNING:
                failed = code != TRAVEL
                break
            if guarded:
                intrusion = max(intrusion, margin_intrusion(y, p, st, normal_margin, ws))
            if plane_guarded:
                plane_sum += plane_intrusion(y, p, plane_margin, slopes, cp, ws)
            if fev_budget > 0.0 and ws[K.W_COUNT, K.C_NFEV] - fev0 > fev_budget:
                break
        fevs[i] = ws[K.W_COUNT, K.C_NFEV] - fev0
        cost = st[ST_ERR_NUM] + dist * max(travel - s, 0.0)
        cost += cfg[CF_FAIL] * travel * plane_sum / horizon
        if not failed and s < travel:
            cost += cfg[CF_FAIL] * max(travel * st[ST_T] / pace_s - s, 0.0)
        cost += cfg[CF_FAIL] * travel * intrusion
        if failed or not np.isfinite(cost):
            cost = st[ST_ERR_NUM] + cfg[CF_FAIL] * travel
            if not np.isfinite(cost):
                cost = 1e300
        costs[i] = cost


def predict(state: BenchState, plans: np.ndarray, pace_s: float = 1.0, normal_margin: float = 0.0,
            plane_margin: float = 0.0, fev_budget: float = 0.0, work: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Costs, distances and outcome codes of the candidates ``plans`` (n x horizon x 2) from ``state``; ``pace_s``
    (module docstring) is half the env's 2 s time limit by default; ``normal_margin`` (a fraction of the normal
    load) is the safety margin, ``plane_margin`` (m) the plane margin and ``fev_budget`` the work budget of one
    candidate (module docstring; zero: none); ``work`` (n,), if given, gets each candidate's evaluations."""
    plans = np.ascontiguousarray(plans, dtype=np.float64)
    n, horizon = plans.shape[:2]
    costs, dists, codes = np.empty(n), np.empty((n, horizon)), np.empty((n, horizon), dtype=np.int64)
    fevs = work if work is not None else np.empty(n)
    s = state
    rollout_costs(s.y, s.p, s.modes, s.armed, s.st, s.ref, s.cfg, s.bc, s.bs, s.queue, plans, float(pace_s), costs,
                  dists, codes, fevs, float(normal_margin), float(plane_margin), float(fev_budget))
    return costs, dists, codes


def warm_up(env) -> None:
    """Compile :func:`step_state` and :func:`rollout_costs` (with the argument types the controllers pass) from a
    reset v1 ``env``; the env is left alone."""
    state = snapshot(env)
    predict(state, np.zeros((2, 3, 2)))
    predict(state, np.zeros((2, 3, 2)), 1.0, 0.1)
    predict(state, np.zeros((2, 3, 2)), 1.0, 0.1, 0.001)
    step_state(state.y, state.p, state.modes, state.armed, state.st, state.ref, state.cfg, state.bc, state.bs,
               state.queue, np.zeros(2), np.zeros(2), np.zeros(OBS_DIM), np.zeros(N_INFO), new_workspace())
