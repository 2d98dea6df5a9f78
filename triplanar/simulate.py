"""``simulate(model) -> SimulationResult``: one constant-force shear test, from rest to a stop.

Modelled on ``scipy.integrate.solve_ivp``: a plain function returning a result with ``status``,
``message`` and ``success``. Methods:

* ``"dopri5"`` (default): adaptive Dormand-Prince 5(4), for traces.
* ``"rk4"``: classical Runge-Kutta at fixed step ``dt`` (what the Gymnasium env uses).
* ``"euler"``: the paper's explicit Euler (eq. 40) at fixed step ``dt``, for comparison.

Every method projects the contact points back onto their planes after each step (drift < 1e-12 m). The
integration itself is :func:`triplanar.driver.drive`, the same compiled driver the Gymnasium environment uses;
this function decides whether the block starts at all, records every accepted step and names the ending.
"""

from __future__ import annotations

import math

import numpy as np

from . import driver, stepping
from . import kernel as K
from .model import Model
from .outcome import Outcome, describe
from .result import Event, SimulationResult
from .statics import holds, sliding_threshold, start_motion

METHODS = {"euler": stepping.METHOD_EULER, "rk4": stepping.METHOD_RK4, "dopri5": stepping.METHOD_DOPRI5}
DEFAULT_DT = {"euler": 1e-5, "rk4": 1e-3, "dopri5": 1e-4}
SLOW_SPEED_M_S = 1e-5  # below this (every contact point) the block is checked for arrest

MAX_LOGGED_EVENTS = 10_000  # events kept in a result's record (the counts go on past it)
DOPRI5_FIRST_ROWS = 4096    # recording buffer for an adaptive run; it doubles when full, up to max_rows


def simulate(model: Model, *, method: str = "dopri5", rtol: float = 1e-8, atol: float = 1e-11,
             dt: float | None = None, travel_m: float = 0.08, t_max_s: float = 5.0,
             max_rows: int = 2_000_000) -> SimulationResult:
    """Run one test of ``model`` until CP1 has moved ``travel_m`` along e1, or something stops it.

    Args:
        model: what to simulate (:func:`triplanar.model.paper_model` builds the paper's cases).
        method: ``"dopri5"``, ``"rk4"`` or ``"euler"``.
        rtol, atol: DOPRI5 tolerances (per state component, RMS norm).
        dt: fixed step for RK4 and Euler (defaults 1 ms and 10 us); DOPRI5's first trial step.
        travel_m: stop when CP1 has moved this far along e1 (the paper's Delta q1 = 8 cm).
        t_max_s: stop at this time after the start of sliding.

    Returns a :class:`SimulationResult`. Its ``status`` is one of ``travel``, ``held`` (never started),
    ``arrested``, ``lift_off``, ``mass_centre_outside``, ``left_plane``, ``time_limit``, ``failed``.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    for name, value in (("rtol", rtol), ("atol", atol), ("travel_m", travel_m), ("t_max_s", t_max_s)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value}")
    if dt is not None and not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number, got {dt}")
    model.validate()
    h = dt if dt is not None else DEFAULT_DT[method]
    p = model.kernel_params_cached.copy()

    # With a rising actuator force, sliding starts when the force first overcomes friction.
    t_start, thrust0 = 0.0, model.loading.force_N
    y0 = model.initial_state()
    if model.loading.rise_time_s > 0:
        threshold = sliding_threshold(model, y0, upper_N=model.loading.force_N)
        if math.isnan(threshold):
            threshold = 0.0  # it cannot even hold without thrust: it slides as soon as the actuator starts
        if math.isinf(threshold):
            return _held(model, y0, method, "the commanded force never overcomes friction (static equilibrium "
                         f"exists at {model.loading.force_N:g} N)")
        thrust0 = threshold
        t_start = -model.loading.rise_time_s * math.log1p(-threshold / model.loading.force_N)
        p[K.P_F0] = thrust0
        y0 = model.initial_state(thrust_N=thrust0)
    elif holds(model, y0, thrust0):  # (a rising force starts at the threshold: it slides by construction)
        return _held(model, y0, method, f"friction holds the block at {thrust0:g} N: a static equilibrium exists, "
                     "so it never starts to slide")

    ws = driver.new_workspace()
    log = np.empty((MAX_LOGGED_EVENTS, 3))
    capacity = min(max_rows, DOPRI5_FIRST_ROWS if method == "dopri5" else int(t_max_s / h) + 8)
    out_t, out_aux = np.empty(capacity), np.empty((capacity, K.N_AUX))
    out_y, out_dy = np.empty((capacity, K.N_STATE)), np.empty((capacity, K.N_STATE))
    rows, t, y = 0, 0.0, y0.copy()
    x1_target = _cp1_x1(y0, p) + travel_m
    armed = np.zeros(5, dtype=np.bool_)
    modes = K.sliding_modes()
    opts = stepping.StepOptions(METHODS[method], rtol, atol, t_max_s, x1_target, SLOW_SPEED_M_S, 0.0)
    with K.user_force(p, model.user_wrench if model.force_effects else None):
        converged, consistency = start_motion(p, modes, y0)
        K.modes_of(ws)[:] = modes  # (the driver keeps them there)
        while True:
            rec = stepping.Recording(True, out_t, out_y, out_dy, out_aux, log)
            code, event, rows, h, t = driver.drive(t, y, p, armed, h, opts, rec, rows, ws)
            if code != Outcome.BUFFER_FULL or capacity >= max_rows:
                break
            capacity = min(2 * capacity, max_rows)
            out_t, out_y, out_dy, out_aux = (np.concatenate([a, np.empty((capacity - len(a),) + a.shape[1:])])
                                             for a in (out_t, out_y, out_dy, out_aux))
    if code == Outcome.BUFFER_FULL:
        status, message = Outcome.FAILED, f"more than max_rows = {max_rows} steps; raise max_rows or dt"
    else:
        status, message = Outcome(code), describe(Outcome(code), event, t, travel_m)
    count = ws[K.W_COUNT]
    return SimulationResult(t=out_t[:rows].copy(), y=out_y[:rows].copy(), dydt=out_dy[:rows].copy(),
                            aux=out_aux[:rows].copy(), status=status, message=message, model=model, method=method,
                            t_start_s=t_start, travel_target_m=travel_m, incipient_converged=converged,
                            incipient_consistency=consistency,
                            events=tuple(Event(float(r[0]), int(r[1]), Outcome(int(r[2]))) for r in
                                         log[:int(count[K.C_NLOG])]),
                            nfev=int(count[K.C_NFEV]), n_steps=int(count[K.C_NSTEP]),
                            n_rejected=int(count[K.C_NREJECT]), n_statics=int(count[K.C_NLP]),
                            n_starts=1 + int(count[K.C_NSTART]))


def _held(model: Model, y0: np.ndarray, method: str, message: str) -> SimulationResult:
    aux = np.zeros(K.N_AUX)
    K.dynamics_ws(0.0, y0, model.kernel_params_cached.copy(), np.empty(K.N_STATE), aux, K.new_workspace())
    return SimulationResult(t=np.zeros(1), y=y0[None, :].copy(), dydt=np.zeros((1, K.N_STATE)), aux=aux[None, :],
                            status=Outcome.HELD, message=message, model=model, method=method,
                            t_start_s=math.inf, travel_target_m=0.0, incipient_converged=True,
                            incipient_consistency=1.0)


def _cp1_x1(y: np.ndarray, p: np.ndarray) -> float:
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    return float(cps[0, 0])

