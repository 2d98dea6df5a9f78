"""What advances the kernel's state in time: the steppers, event location, stick and slip, start modes.

:func:`integrate` (and :func:`integrate_ws`, which takes a workspace) steps the one right-hand side of
:mod:`triplanar.kernel` with Euler (the paper's eq. 40), RK4 or adaptive DOPRI5, locates events, handles a contact
or the tip that stops slipping or whose static friction gives way (:func:`apply_mode_event_ws`), and returns at
terminal events and at ``SLOW`` (all contacts nearly stopped: :mod:`triplanar.driver` decides arrest with the
statics LP, :mod:`triplanar.equilibrium`). :func:`incipient_directions` and :func:`start_motion_ws` choose how a
block at rest starts to move. ``docs/physics.md`` explains the choices; the tests in ``tests/triplanar/test_physics.py``
measure them.

numba keys its on-disk cache on this file only, while these functions compile the kernel in;
:func:`triplanar.compiled_cache.drop_if_stale` discards this module's cache when the kernel changes.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from . import kernel as K
from .compiled_cache import drop_if_stale, numba_cache_dir
from .kernel import (A_ACC, A_SLIP, A_SPEED, A_STICK, A_STICK_F, A_TIP_F, A_TIP_STICK, C_NEVENT, C_NLOG, C_NREJECT,
                     C_NSTEP, EV_RELEASE, EV_SLOW, EV_STOP, EV_TIP_RELEASE, EV_TIP_STOP, N_AUX, N_EVENTS,
                     N_KERNEL_WS_ROWS, N_STATE, M_D0, M_STUCK, M_TIP_STUCK, P_C, P_CASE, P_TANEF, SLIP_BLEND, S_DC,
                     S_DTIP, S_F, S_Q, S_V, S_W, S_WLOAD, W_COUNT, W_MODES, ZERO_SPEED, _cross, _rotate,
                     allocate_workspace, event_values_ws, kinetic_energy_ws, modes_of, project_ws, quat_to_matrix,
                     rhs_ws)
from .layout import Layout
from .outcome import BUFFER_FULL, EVENT_OUTCOME, FAILED, RELEASED, RUNNING, SLOW, STOPPED, TIME_LIMIT

drop_if_stale(numba_cache_dir(__file__), "stepping.*.nb[ic]",
              [Path(K.__file__), Path(K.__file__).parent / "outcome.py", Path(K.__file__).parent / "layout.py"],
              "stepping.kernel.sha256")

# This module's scratch rows, after the kernel's (see the note on scratch memory in triplanar.kernel).
WORKSPACE = Layout("SW_", "N_WS_ROWS", [
    ("STAGES", 8, "Runge-Kutta stages and the stage argument (state vectors)"),
    *((name, 1, "state vector") for name in ("DY", "YNEW", "ERR", "YHI")),
    *((name, 1, "aux vector") for name in ("AUX", "AUXNEW", "AUXHI", "AUXMODE")),
    *((name, 1, "event-value vector") for name in ("EVOLD", "EVNEW", "EVLOC")),
    ("DIRS", 2, "incipient directions and their update (12 each)"),
    ("SITE_D", 1, "a stopping site's initial slip direction"),
    ("SITE_V", 1, "a site's slip velocity"),
    ("R", 3, "3x3 rotation matrix"),
    ("ARM", 1, "3-vector: a contact point's arm from the mass centre")], start=N_KERNEL_WS_ROWS)
(SW_STAGES, SW_DY, SW_YNEW, SW_ERR, SW_YHI, SW_AUX, SW_AUXNEW, SW_AUXHI, SW_AUXMODE, SW_EVOLD, SW_EVNEW, SW_EVLOC,
 SW_DIRS, SW_SITE_D, SW_SITE_V, SW_R, SW_ARM, N_WS_ROWS) = WORKSPACE.offsets()
assert WORKSPACE.named_in(globals())


@njit(cache=True, error_model="numpy")
def new_workspace() -> np.ndarray:
    """Scratch memory for the steppers and everything below them (the kernel's rows included)."""
    return allocate_workspace(np.int64(N_WS_ROWS))  # (not a literal: one compiled version for every module)


MAX_MISSED_STOPS = 8  # predicted stops of one site in a row that may miss before a full step is taken



# -- one step of each method -------------------------------------------------------------------
# Dormand-Prince 5(4) coefficients (Hairer, Norsett & Wanner, Solving ODEs I, table 5.2).
_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_A = np.array([
    [0, 0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]])
_E = np.array([71 / 57600, 0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])

METHOD_EULER, METHOD_RK4, METHOD_DOPRI5 = 0, 1, 2


@njit(cache=True, error_model="numpy")
def step_ws(method: int, t: float, y: np.ndarray, h: float, p: np.ndarray, y_new: np.ndarray,
            err: np.ndarray, aux: np.ndarray, ws: np.ndarray) -> bool:
    """One step of size ``h`` from (t, y) into ``y_new`` (not projected); ``err`` gets DOPRI5's estimate.
    Every method's first stage is f(t, y): the caller keeps it in the workspace's first stage row (``SW_STAGES``,
    see :func:`integrate_ws`)."""
    n = y.shape[0]
    k = ws[SW_STAGES:SW_STAGES + 7, :N_STATE]
    tmp = ws[SW_STAGES + 7, :N_STATE]
    if method == METHOD_EULER:  # the paper's eq. 40
        for i in range(n):
            y_new[i] = y[i] + h * k[0, i]
        return True
    if method == METHOD_RK4:
        # (rows of ws, not of k: k's rows are not contiguous to numba, and rhs_ws would compile twice)
        k1, k2 = ws[SW_STAGES, :N_STATE], ws[SW_STAGES + 1, :N_STATE]
        k3, k4 = ws[SW_STAGES + 2, :N_STATE], ws[SW_STAGES + 3, :N_STATE]
        for i in range(n):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        if not rhs_ws(t + 0.5 * h, tmp, p, k2, aux, ws):
            return False
        for i in range(n):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        if not rhs_ws(t + 0.5 * h, tmp, p, k3, aux, ws):
            return False
        for i in range(n):
            tmp[i] = y[i] + h * k3[i]
        if not rhs_ws(t + h, tmp, p, k4, aux, ws):
            return False
        for i in range(n):
            y_new[i] = y[i] + h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
        return True
    for s in range(1, 7):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += _A[s, j] * k[j, i]
            tmp[i] = y[i] + h * acc
        if not rhs_ws(t + _C[s] * h, tmp, p, ws[SW_STAGES + s, :N_STATE], aux, ws):
            return False
    for i in range(n):
        y_new[i] = tmp[i]  # stage 7 is the 5th-order solution (FSAL)
        e = 0.0
        for j in range(7):
            e += _E[j] * k[j, i]
        err[i] = h * e
    return True


@njit(cache=True, error_model="numpy")
def _error_norm(y: np.ndarray, y_new: np.ndarray, err: np.ndarray, rtol: float, atol: float) -> float:
    """RMS error over the dynamic state (pose, velocities) and the tip offset. The force record and the
    energy integrals are left out: they are quadratures that feed nothing back, and including them (they
    scale with mass and force) would make similar systems (paper cases D-F) take different steps."""
    s = 0.0
    n = 0
    for i in range(S_WLOAD):
        if i == S_F:
            continue
        sc = atol + rtol * max(abs(y[i]), abs(y_new[i]))
        s += (err[i] / sc) ** 2
        n += 1
    return math.sqrt(s / n)


@njit(cache=True, error_model="numpy")
def _advance(method, t, y, h, p, y_new, err, aux, ws: np.ndarray) -> bool:
    """A step followed by projection; then evaluate dynamics at the new state to fill ``aux`` (and f(y_new) in
    ``ws[SW_DY]``). The step's first stage f(t, y) must be in ``ws[SW_STAGES]`` (see :func:`integrate_ws`)."""
    if not step_ws(method, t, y, h, p, y_new, err, aux, ws):
        return False
    if not project_ws(y_new, p, ws):
        return False
    if not rhs_ws(t + h, y_new, p, ws[SW_DY, :N_STATE], aux, ws):
        return False
    for i in range(y_new.shape[0]):
        if not math.isfinite(y_new[i]):
            return False
    return True


class StepOptions(NamedTuple):
    """How a run steps and when it ends: what :func:`integrate_ws` and :func:`triplanar.driver.drive` take after the
    state. Compiled as a named tuple (a struct of scalars passed by value): its fields are read like local
    variables, it adds no allocation or pointer chasing in the env's hot loop, and one tuple type means one compiled
    version; a jitclass or structref would be a heap object behind a pointer, boxed on every call from Python, with
    its own typing and compile cost. Build it with the same field types at every call site (``method`` an integer,
    the rest floats), or numba compiles the whole tree again."""
    method: int  # METHOD_EULER, METHOD_RK4 or METHOD_DOPRI5
    rtol: float  # DOPRI5's tolerances (per state component, RMS norm: _error_norm)
    atol: float
    t_end: float  # s: the run returns TIME_LIMIT here
    x1_target: float  # m: the run ends with TRAVEL when CP1's e1 coordinate reaches it
    slow_speed: float  # m/s: every contact point slower: SLOW (the caller checks arrest); stops at a tenth of it
    energy_tol: float  # J: driver.drive redoes a stretch whose energy balance is off by more, with DOPRI5; 0: no check


class Recording(NamedTuple):
    """Where a run writes what it records (compiled as a named tuple of arrays, like :class:`StepOptions`).

    With ``on``, every accepted step's time, state, derivative f(t, y) and aux vector are written to ``t``, ``y``,
    ``dy``, ``aux`` (rows of equal count); every event that happens is appended to ``log`` (rows: time, event index,
    outcome) while it has room, recorded or not. The env records nothing: one-row buffers and an empty log, of the
    same array types as simulate's, so that the steppers are compiled once."""
    on: bool
    t: np.ndarray
    y: np.ndarray
    dy: np.ndarray
    aux: np.ndarray
    log: np.ndarray


@njit(cache=True, error_model="numpy")
def integrate(t0: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray, armed: np.ndarray, h: float,
              opts: StepOptions, rec: Recording):
    """:func:`integrate_ws` with its own scratch memory, recording from row 0; ``modes`` are updated in place."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    out = integrate_ws(t0, y, p, armed, h, opts, rec, 0, ws)
    modes[:] = modes_of(ws)
    return out


# Over the complexity limit (pyproject.toml) knowingly: a compiled kernel, whose split into helpers must be
# shown to keep results bitwise (benchmarks/fingerprint.py), speed (benchmarks/bench_speed_ab.py) and compile time
# (benchmarks/bench_compile.py). A split into three sections (a step, its event, what follows) was bitwise the same
# and as fast, but compiled on their own (forceinline) the sections took compile time from 45 to 64 CPU-seconds
# (docs/performance.md).
@njit(cache=True, error_model="numpy")
def integrate_ws(t0: float, y: np.ndarray, p: np.ndarray, armed: np.ndarray,  # noqa: C901 (see above)
                 h: float, opts: StepOptions, rec: Recording, row0: int, ws: np.ndarray):
    """Integrate from (t0, y) until a terminal event, ``opts.t_end`` or a full buffer; ``y`` ends as the final state.

    ``h`` is the fixed step (Euler, RK4) or the first trial step (DOPRI5). Events are located to 1e-13 s
    by re-stepping from the last accepted state with a shorter step (Illinois regula falsi on the step),
    so a terminal event's row lies on the event. A contact or the tip that stops slipping, or whose static
    friction gives way, is handled here (:func:`apply_mode_event_ws`); the run returns to the caller for the
    rest: terminal events, and ``SLOW`` (a possible arrest: the caller decides with the statics LP; the caller is
    :func:`triplanar.driver.drive`, which takes the same arguments in the same order).
    A fixed step that would carry a sliding site past its predicted stop ends there instead
    (:func:`_predicted_stop`, :func:`_step_to_stop`), so the stop is handled where it happens.
    ``armed`` (5 flags, updated in place): whether the all-slow event, each contact's and the tip's stop
    event may fire; each arms once its speed has exceeded twice its threshold, so a start from rest does
    not count. ``opts`` (:class:`StepOptions`) holds the method, tolerances and endings (``energy_tol`` is the
    driver's); ``rec`` (:class:`Recording`) the buffers: with ``rec.on`` every accepted step is written from row
    ``row0``; the start is written only when ``row0`` is 0 (a continuation's start is the caller's last row).
    ``rec.dy`` gets f(t, y) at each row, the derivative the run goes on with (at a stick/slip change, the one after
    it; a continuation rewrites its start row's, as a restart may have changed the modes). Every event that happens
    is appended to ``rec.log``; the workspace's counters (``kernel.C_*``) count steps, rejections, events and log
    rows.
    Returns (outcome (:mod:`triplanar.outcome`), event index or -1, rows in the buffers, last step size, final
    time), as :func:`triplanar.driver.drive` does.
    """
    method, rtol, atol, t_max = opts.method, opts.rtol, opts.atol, opts.t_end
    x1_target, slow_speed = opts.x1_target, opts.slow_speed
    record, out_t, out_y, out_dy, out_aux, log = rec.on, rec.t, rec.y, rec.dy, rec.aux, rec.log
    n = y.shape[0]
    aux = ws[SW_AUX, :N_AUX]
    dummy = ws[SW_DY, :N_STATE]
    # f(t, y) of the current state lives in the first stage row: every step from (t, y), including retries and
    # event searches, starts with it, and the evaluation at a step's end (for aux) provides the next one.
    k1 = ws[SW_STAGES, :N_STATE]
    rows = row0
    if not rhs_ws(t0, y, p, k1, aux, ws):
        return FAILED, -1, rows, h, t0
    ev_old = ws[SW_EVOLD, :N_EVENTS]
    ev_new = ws[SW_EVNEW, :N_EVENTS]
    event_values_ws(y, p, aux, x1_target, slow_speed, ev_old, ws)
    if record and row0 == 0:
        out_t[0] = t0
        out_y[0] = y
        out_aux[0] = aux
        rows = 1
    if record:  # the derivative the run goes on with (after a restart, with the new modes)
        out_dy[max(row0 - 1, 0)] = k1
    t = t0
    y_new = ws[SW_YNEW, :N_STATE]
    err = ws[SW_ERR, :N_STATE]
    aux_new = ws[SW_AUXNEW, :N_AUX]
    count = ws[W_COUNT]
    for k in range(EV_SLOW):
        if ev_old[k] > 0.0:
            _log_event(log, count, t, k)
            return EVENT_OUTCOME[k], k, rows, h, t
    fixed = method != METHOD_DOPRI5
    # Consecutive predicted steps of each site that did not end in its stop. A stop is usually reached in a few
    # (each one refines the last); a slip that turns instead of stopping can make them shrink towards zero
    # (tests/triplanar/test_physics.py::test_a_turning_slip_does_not_stall_fixed_steps), so after MAX_MISSED_STOPS the next
    # step is a full one.
    missed = np.zeros(4, np.int64)
    while True:
        if record and rows >= out_t.shape[0]:
            return BUFFER_FULL, -1, rows, h, t
        if t_max - t <= 1e-9 * h:
            return TIME_LIMIT, -1, rows, h, t
        h_try = min(h, t_max - t)
        site = -1
        if fixed:
            site, tau = _predicted_stop(y, p, aux, armed, slow_speed, missed, ws)
            if site < 0 or tau >= h_try:
                site = -1
            else:
                tau = max(tau, 1e-6 * h_try)  # (always progress: a huge deceleration must not stall time)
        if site >= 0:
            h_try = _step_to_stop(method, t, y, tau, h_try, p, site, slow_speed, y_new, err, aux_new, ws)
            if h_try < 0.0:
                return FAILED, -1, rows, h, t
        elif not _advance(method, t, y, h_try, p, y_new, err, aux_new, ws):
            if not fixed and h_try > 1e-12:
                h = 0.25 * h_try
                count[C_NREJECT] += 1.0
                continue
            return FAILED, -1, rows, h, t
        h_next = h
        if not fixed:
            en = _error_norm(y, y_new, err, rtol, atol)
            if en > 1.0:
                h = h_try * max(0.2, 0.9 * en ** -0.2)
                if h < 1e-12:
                    return FAILED, -1, rows, h, t
                count[C_NREJECT] += 1.0
                continue
            h_next = h_try * min(5.0, 0.9 * en ** -0.2) if en > 0 else h_try * 5.0
        event_values_ws(y_new, p, aux_new, x1_target, slow_speed, ev_new, ws)
        hit = -1
        for k in range(N_EVENTS):
            if (k == EV_SLOW and not armed[0]) or (EV_STOP <= k < EV_RELEASE and not armed[k - EV_STOP + 1]) \
                    or (k == EV_TIP_STOP and not armed[4]):
                continue
            if ev_new[k] > 0.0 and ev_old[k] <= 0.0:
                hit = k
                break
        predicted = site >= 0 and hit == (EV_TIP_STOP if site == 3 else EV_STOP + site)
        if site >= 0 and not predicted:
            missed[site] += 1
        else:
            missed[:] = 0
        if hit >= 0 and not predicted:  # (a predicted stop is already where it happens)
            h_ev = _locate(method, t, y, h_try, p, ev_old[hit], ev_new[hit], hit, x1_target, slow_speed,
                           y_new, err, aux_new, ws)
            if h_ev < 0.0:
                return FAILED, -1, rows, h, t
            h_try = h_ev
        t = t + h_try
        for i in range(n):
            y[i] = y_new[i]
        dy_ready = hit < 0 or predicted  # (an event search leaves f of its last trial in dummy)
        count[C_NSTEP] += 1.0
        status = RUNNING
        if hit >= 0:
            status = EVENT_OUTCOME[hit]
            _log_event(log, count, t, hit)
        second_stop = status == STOPPED and hit != EV_TIP_STOP and ws[W_MODES, M_STUCK] >= 0.0
        if status == STOPPED and not second_stop or status == RELEASED:
            apply_mode_event_ws(hit, t, y, p, ws)
            if hit == EV_TIP_STOP:
                armed[4] = False
            elif hit < EV_RELEASE:
                armed[hit - EV_STOP + 1] = False
            if not rhs_ws(t, y, p, dummy, aux_new, ws):
                return FAILED, -1, rows, h, t
            dy_ready = True
            status = RUNNING
        elif second_stop:
            status = SLOW
        # (the new d0 enters neither the right-hand side nor the events: it is used only below SLIP_BLEND, where it
        # is not refreshed, so f(t, y) and the event values stay valid)
        _refresh_directions(y, p, aux_new, ws)
        if hit < 0:
            ev_old[:] = ev_new
        else:
            event_values_ws(y, p, aux_new, x1_target, slow_speed, ev_old, ws)
        aux[:] = aux_new
        if dy_ready:
            k1[:] = dummy
        elif not rhs_ws(t, y, p, k1, aux_new, ws):
            return FAILED, -1, rows, h, t
        if ev_old[EV_SLOW] < -slow_speed:
            armed[0] = True  # arrest can only be detected once the block has really moved
        for i in range(3):
            if ev_old[EV_STOP + i] < -0.1 * slow_speed:
                armed[i + 1] = True
        if ev_old[EV_TIP_STOP] < -0.1 * slow_speed:
            armed[4] = True
        if record:
            out_t[rows] = t
            out_y[rows] = y
            out_dy[rows] = k1
            out_aux[rows] = aux_new
            rows += 1
        if status != RUNNING:
            return status, hit, rows, h, t
        h = h_next


@njit(cache=True, error_model="numpy")
def log_outcome(log: np.ndarray, count: np.ndarray, t: float, event: int, outcome: int) -> None:
    """Append (t, event index or -1, outcome) to ``log`` while it has room (``count``: the workspace's counters)."""
    row = int(count[C_NLOG])
    if row < log.shape[0]:
        log[row, 0] = t
        log[row, 1] = event
        log[row, 2] = outcome
        count[C_NLOG] += 1.0


@njit(cache=True, error_model="numpy")
def _log_event(log: np.ndarray, count: np.ndarray, t: float, event: int) -> None:
    count[C_NEVENT] += 1.0
    log_outcome(log, count, t, event, EVENT_OUTCOME[event])


@njit(cache=True, error_model="numpy")
def _site_velocity(y: np.ndarray, p: np.ndarray, aux: np.ndarray, site: int, ws: np.ndarray,
                   out: np.ndarray) -> None:
    """Slip velocity of contact point ``site`` (0-2), or of the aft face on the tip (3, from ``aux``)."""
    if site == 3:
        for k in range(3):
            out[k] = aux[A_SLIP + k]
        return
    R = ws[SW_R:SW_R + 3, :3]
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    arm = ws[SW_ARM, :3]
    _rotate(R, p, P_C + 3 * site, arm)
    c0, c1, c2 = _cross(y[S_W], y[S_W + 1], y[S_W + 2], arm[0], arm[1], arm[2])
    out[0], out[1], out[2] = y[S_V] + c0, y[S_V + 1] + c1, y[S_V + 2] + c2


@njit(cache=True, error_model="numpy")
def _predicted_stop(y: np.ndarray, p: np.ndarray, aux: np.ndarray, armed: np.ndarray,
                    slow_speed: float, missed: np.ndarray, ws: np.ndarray) -> tuple:
    """The sliding site (contact 0-2 or the tip, 3) that friction will stop first, and when, extrapolating
    its deceleration along its slip: ``|v| / (-a . v/|v|)``; (-1, inf) if none decelerates. Sites that
    missed MAX_MISSED_STOPS predicted stops in a row (``missed``) are left out. Sets
    ``ws[SW_SITE_D]`` to that site's slip direction.

    Why: a fixed step cannot see a slip that stops and would reverse inside it (friction's direction flips
    with v/|v|, and the step ends with a spurious slip the other way); stepping to the stop instead lets the
    stop event fire where it happens."""
    modes = ws[W_MODES]
    best, best_tau = -1, math.inf
    v = ws[SW_SITE_V, :3]
    stuck = int(modes[M_STUCK])
    rubs = p[P_TANEF] > 0.0 and p[P_CASE] == 0.0 and modes[M_TIP_STUCK] == 0.0
    for site in range(4):
        if missed[site] >= MAX_MISSED_STOPS:
            continue
        if site < 3 and (site == stuck or not armed[site + 1]) or site == 3 and not (rubs and armed[4]):
            continue
        _site_velocity(y, p, aux, site, ws, v)
        speed = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
        if speed <= 0.1 * slow_speed:
            continue
        decel = -(aux[A_ACC + 3 * site] * v[0] + aux[A_ACC + 3 * site + 1] * v[1]
                  + aux[A_ACC + 3 * site + 2] * v[2]) / speed
        if decel > 0.0 and speed / decel < best_tau:
            best, best_tau = site, speed / decel
            for k in range(3):
                ws[SW_SITE_D, k] = v[k] / speed
    return best, best_tau


@njit(cache=True, inline="always", error_model="numpy")  # (one caller: DEVELOPERS.md, compile time)
def _step_to_stop(method, t, y, h, h_max, p, site, slow_speed, y_new, err, aux_new, ws: np.ndarray) -> float:
    """Step to where the slip of ``site`` along its initial direction d (``ws[SW_SITE_D]``) reaches zero, from
    the guess ``h`` (at most ``h_max``): the secant method on u(h) = v(t + h) . d, which (unlike the speed) is
    smooth through the stop. Stops refining when |u| < slow_speed / 50, well inside the stop event's
    slow_speed / 10. Returns the step taken (``y_new``, ``aux_new`` filled there), or -1 if a step failed."""
    d = ws[SW_SITE_D, :3]
    v = ws[SW_SITE_V, :3]
    _site_velocity(y, p, ws[SW_AUX, :N_AUX], site, ws, v)
    h0, u0 = 0.0, v[0] * d[0] + v[1] * d[1] + v[2] * d[2]
    h1 = h
    for it in range(6):
        if not _advance(method, t, y, h1, p, y_new, err, aux_new, ws):
            return -1.0
        _site_velocity(y_new, p, aux_new, site, ws, v)
        u1 = v[0] * d[0] + v[1] * d[1] + v[2] * d[2]
        if abs(u1) < 0.02 * slow_speed or u1 == u0 or it == 5:
            break
        h2 = h1 - u1 * (h1 - h0) / (u1 - u0)
        if not 0.0 < h2 <= h_max:
            break
        h0, u0, h1 = h1, u1, h2
    return h1


@njit(cache=True, error_model="numpy")
def _refresh_directions(y: np.ndarray, p: np.ndarray, aux: np.ndarray, ws: np.ndarray) -> None:
    """At a step boundary, each site sliding faster than SLIP_BLEND gets its current slip direction as d0
    (M_D0), so the low-speed blend of a slowing site mixes with where it is going, not with a stale start."""
    modes = ws[W_MODES]
    R = ws[SW_R:SW_R + 3, :3]
    quat_to_matrix(y[S_Q:S_Q + 4], R)
    tmp = ws[SW_ARM, :3]
    stuck = int(modes[M_STUCK])
    for j in range(3):
        sp = aux[A_SPEED + j]
        if j == stuck or sp < SLIP_BLEND:
            continue
        _rotate(R, p, P_C + 3 * j, tmp)
        c0, c1, c2 = _cross(y[S_W], y[S_W + 1], y[S_W + 2], tmp[0], tmp[1], tmp[2])
        modes[M_D0 + 3 * j] = (y[S_V] + c0) / sp
        modes[M_D0 + 3 * j + 1] = (y[S_V + 1] + c1) / sp
        modes[M_D0 + 3 * j + 2] = (y[S_V + 2] + c2) / sp
    slip = math.sqrt(aux[A_SLIP] ** 2 + aux[A_SLIP + 1] ** 2 + aux[A_SLIP + 2] ** 2)
    if p[P_TANEF] > 0.0 and p[P_CASE] == 0.0 and modes[M_TIP_STUCK] == 0.0 and slip >= SLIP_BLEND:
        for k in range(3):
            modes[M_D0 + 9 + k] = aux[A_SLIP + k] / slip


@njit(cache=True, error_model="numpy")
def apply_mode_event_ws(event: int, t: float, y: np.ndarray, p: np.ndarray, ws: np.ndarray) -> None:
    """A contact or the tip stopped slipping (it sticks if static friction can hold it, else slips anew
    from rest where the load drives it), or a stuck one's friction gave way (it slips).

    A stopping site's last ~1e-6 m/s is removed by the velocity projection (the correction of least
    kinetic energy); that kinetic energy is booked as dissipation at the site, so the balance stays exact.
    """
    modes = ws[W_MODES]
    if event == EV_RELEASE or event == EV_TIP_RELEASE:
        # Static friction reached its cone: the site slips opposite to the friction force it had, which is
        # the continuous continuation (the slip acceleration starts from zero along that direction).
        aux = ws[SW_AUXMODE, :N_AUX]
        rhs_ws(t, y, p, ws[SW_DY, :N_STATE], aux, ws)
        tip = event == EV_TIP_RELEASE
        site = 3 if tip else int(modes[M_STUCK])
        base = A_TIP_F if tip else A_STICK_F
        norm = math.sqrt(aux[base] ** 2 + aux[base + 1] ** 2 + aux[base + 2] ** 2)
        if tip:
            modes[M_TIP_STUCK] = 0.0
        else:
            modes[M_STUCK] = -1.0
        if norm > 0.0:
            for k in range(3):
                modes[M_D0 + 3 * site + k] = -aux[base + k] / norm
            return
    else:
        tip = event == EV_TIP_STOP
        before = kinetic_energy_ws(y, p, ws)
        if tip:
            modes[M_TIP_STUCK] = 1.0
        else:
            modes[M_STUCK] = float(event - EV_STOP)
        project_ws(y, p, ws)
        y[S_DTIP if tip else S_DC + event - EV_STOP] += before - kinetic_energy_ws(y, p, ws)
        aux = ws[SW_AUXMODE, :N_AUX]
        rhs_ws(t, y, p, ws[SW_DY, :N_STATE], aux, ws)
        if aux[A_TIP_STICK if tip else A_STICK] <= 0.0:
            return
        if tip:
            modes[M_TIP_STUCK] = 0.0
        else:
            modes[M_STUCK] = -1.0
    incipient_directions_ws(t, y, p, 400, ws)


@njit(cache=True, inline="always", error_model="numpy")  # (one caller: DEVELOPERS.md, compile time)
def _locate(method, t, y, h, p, g_lo, g_hi, which, x1_target, slow_speed, y_new, err, aux,
            ws: np.ndarray) -> float:
    """Step length in (0, h] at which event ``which`` crosses zero; fills y_new/aux there. -1 on failure."""
    ev = ws[SW_EVLOC, :N_EVENTS]
    lo, hi = 0.0, h
    f_lo, f_hi = g_lo, g_hi
    side = 0
    y_hi = ws[SW_YHI, :N_STATE]
    aux_hi = ws[SW_AUXHI, :N_AUX]
    y_hi[:] = y_new
    aux_hi[:] = aux
    for _ in range(80):
        if hi - lo < 1e-13:
            break
        mid = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        if not (lo < mid < hi):
            mid = 0.5 * (lo + hi)
        if not _advance(method, t, y, mid, p, y_new, err, aux, ws):
            return -1.0
        event_values_ws(y_new, p, aux, x1_target, slow_speed, ev, ws)
        g = ev[which]
        if g > 0.0:
            hi, f_hi = mid, g
            y_hi[:] = y_new
            aux_hi[:] = aux
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = mid, g
            if side == -1:
                f_hi *= 0.5
            side = -1
            if abs(g) < 1e-14:
                hi = mid
                y_hi[:] = y_new
                aux_hi[:] = aux
                break
    y_new[:] = y_hi
    aux[:] = aux_hi
    return hi


@njit(cache=True, error_model="numpy")
def incipient_directions(t: float, y: np.ndarray, p: np.ndarray, modes: np.ndarray, max_iter: int) -> tuple:
    """:func:`incipient_directions_ws` with its own scratch memory; sets ``modes[M_D0:]``."""
    ws = new_workspace()
    modes_of(ws)[:] = modes
    out = incipient_directions_ws(t, y, p, max_iter, ws)
    modes[:] = modes_of(ws)
    return out


@njit(cache=True, error_model="numpy")
def incipient_directions_ws(t: float, y: np.ndarray, p: np.ndarray, max_iter: int,
                            ws: np.ndarray) -> tuple:
    """Set ``modes[M_D0:]`` to the directions in which the resting sliding sites begin to slip.

    Friction at a site with zero slip must oppose its incipient slip, which depends on all the friction
    directions: a fixed point (directions -> slip accelerations -> directions), damped if it oscillates.
    Returns (converged, consistency): the smallest cosine between a resting site's direction and its
    slip acceleration (1: friction exactly opposes the incipient motion everywhere).
    """
    modes = ws[W_MODES]
    aux = ws[SW_AUXMODE, :N_AUX]
    dy = ws[SW_DY, :N_STATE]
    for k in range(12):
        modes[M_D0 + k] = 0.0
    if not rhs_ws(t, y, p, dy, aux, ws):
        return False, -1.0
    resting = np.zeros(4, np.bool_)
    stuck = int(modes[M_STUCK])
    for j in range(3):
        resting[j] = j != stuck and aux[A_SPEED + j] <= ZERO_SPEED
    slip = math.sqrt(aux[A_SLIP] ** 2 + aux[A_SLIP + 1] ** 2 + aux[A_SLIP + 2] ** 2)
    resting[3] = p[P_TANEF] > 0.0 and p[P_CASE] == 0.0 and modes[M_TIP_STUCK] == 0.0 and slip <= ZERO_SPEED
    d = ws[SW_DIRS, :12]
    new = ws[SW_DIRS + 1, :12]
    d[:] = 0.0
    new[:] = 0.0
    damping = 1.0
    converged = False
    for it in range(max_iter):
        change = 0.0
        for s in range(4):
            if not resting[s]:
                continue
            a0, a1, a2 = aux[A_ACC + 3 * s], aux[A_ACC + 3 * s + 1], aux[A_ACC + 3 * s + 2]
            norm = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            if norm > 1e-12:
                new[3 * s], new[3 * s + 1], new[3 * s + 2] = a0 / norm, a1 / norm, a2 / norm
            for k in range(3):
                change = max(change, abs(new[3 * s + k] - d[3 * s + k]))
        if change < 1e-13:
            converged = True
            break
        if it > 0 and it % 40 == 0:
            damping *= 0.5
        for s in range(4):
            if not resting[s]:
                continue
            norm = 0.0
            for k in range(3):
                d[3 * s + k] = new[3 * s + k] if it == 0 else d[3 * s + k] + damping * (new[3 * s + k] - d[3 * s + k])
                norm += d[3 * s + k] ** 2
            norm = math.sqrt(norm)
            for k in range(3):
                if norm > 0.0:
                    d[3 * s + k] /= norm
                modes[M_D0 + 3 * s + k] = d[3 * s + k]
        if not rhs_ws(t, y, p, dy, aux, ws):
            return False, -1.0
    consistency = 1.0
    for s in range(4):
        if not resting[s]:
            continue
        a0, a1, a2 = aux[A_ACC + 3 * s], aux[A_ACC + 3 * s + 1], aux[A_ACC + 3 * s + 2]
        norm = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        if norm > 1e-12:
            consistency = min(consistency, (a0 * d[3 * s] + a1 * d[3 * s + 1] + a2 * d[3 * s + 2]) / norm)
    return converged, consistency


@njit(cache=True, error_model="numpy")
def start_motion_ws(t: float, y: np.ndarray, p: np.ndarray, ws: np.ndarray) -> tuple:
    """Choose how a block that cannot hold starts to move, and set its stick/slip ``modes`` for it.

    Tries, in order: all contacts sliding with the tip stuck (if it rubs), all sliding, then one contact
    stuck (a pivot) with the tip stuck or sliding. A mode is accepted when its friction opposes every
    resting site's incipient slip and every stuck site's friction lies inside its cone. Returns
    (accepted, consistency) of the chosen mode; if none is consistent, the most consistent is used.
    """
    modes = ws[W_MODES]
    rubs = p[P_TANEF] > 0.0 and p[P_CASE] == 0.0
    n_tip = 2 if rubs else 1
    aux = ws[SW_AUXMODE, :N_AUX]
    best_score, best_stuck, best_tip = -math.inf, -1.0, 0.0
    for mode in range(4 * n_tip):
        stuck = float(mode // n_tip - 1)  # -1 (all slide), then a pivot about CP1, CP2, CP3
        tip = 1.0 if rubs and mode % n_tip == 0 else 0.0  # the tip stuck first, when it rubs
        modes[M_STUCK], modes[M_TIP_STUCK] = stuck, tip
        _, consistency = incipient_directions_ws(t, y, p, 400, ws)
        rhs_ws(t, y, p, ws[SW_DY, :N_STATE], aux, ws)
        holds_stuck = aux[A_STICK] <= 0.0 and aux[A_TIP_STICK] <= 0.0
        score = consistency if holds_stuck else -2.0
        if holds_stuck and consistency > 0.9999:
            return True, consistency
        if score > best_score:
            best_score, best_stuck, best_tip = score, stuck, tip
    modes[M_STUCK], modes[M_TIP_STUCK] = best_stuck, best_tip
    _, consistency = incipient_directions_ws(t, y, p, 400, ws)
    return False, consistency
