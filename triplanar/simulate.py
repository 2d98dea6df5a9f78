"""``simulate(model) -> SimulationResult``: one constant-force shear test, from rest to a stop.

Modelled on ``scipy.integrate.solve_ivp``: a plain function returning a result with ``status``,
``message`` and ``success``. Methods:

* ``"dopri5"`` (default): adaptive Dormand-Prince 5(4), for traces.
* ``"rk4"``: classical Runge-Kutta at fixed step ``dt`` (what the Gymnasium env uses).
* ``"euler"``: the paper's explicit Euler (eq. 40) at fixed step ``dt``, for comparison.

Every method projects the contact points back onto their planes after each step (drift < 1e-12 m).
"""

from __future__ import annotations

import math

import numpy as np

from . import kernel as K
from . import stepping
from .model import Model
from .result import SimulationResult
from .statics import holds, sliding_threshold, start_motion

METHODS = {"euler": stepping.METHOD_EULER, "rk4": stepping.METHOD_RK4, "dopri5": stepping.METHOD_DOPRI5}
DEFAULT_DT = {"euler": 1e-5, "rk4": 1e-3, "dopri5": 1e-4}
SLOW_SPEED_M_S = 1e-5  # below this (every contact point) the block is checked for arrest

_STATUS = {stepping.ST_TRAVEL: "travel", stepping.ST_LIFT_OFF: "lift_off",
           stepping.ST_MC_OUTSIDE: "mass_centre_outside", stepping.ST_LEFT_PLANE: "left_plane",
           stepping.ST_TIME_LIMIT: "time_limit", stepping.ST_STEP_FAILED: "failed"}


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

    with _user_effects(model):
        converged, consistency = start_motion(p, y0)
        t_chunks, y_chunks, a_chunks = [], [], []
        t, y = 0.0, y0.copy()
        x1_target = _cp1_x1(y0, p) + travel_m
        armed = np.zeros(5, dtype=np.bool_)
        rows = min(max_rows, 4096 if method == "dopri5" else int(t_max_s / h) + 8)
        while True:
            out_t, out_y = np.empty(rows), np.empty((rows, K.N_STATE))
            out_aux = np.empty((rows, K.N_AUX))
            n, code, event, h, t = stepping.integrate_ws(METHODS[method], t, y, p, h, rtol, atol, t_max_s, x1_target,
                                                         SLOW_SPEED_M_S, armed, out_t, out_y, out_aux, True,
                                                         K.new_workspace())
            skip = 1 if t_chunks else 0  # each chunk starts with the previous chunk's last row
            t_chunks.append(out_t[skip:n]); y_chunks.append(out_y[skip:n]); a_chunks.append(out_aux[skip:n])
            if code == stepping.ST_BUFFER_FULL and sum(len(c) for c in t_chunks) < max_rows:
                rows = min(2 * rows, max_rows)
                continue
            if code == stepping.ST_SLOW:
                # Every contact slow, or a second one stops while one sticks: can friction hold it all?
                if holds(model, y, K.thrust(t, p), t):
                    status, message = "arrested", (f"arrested at t = {t:.4f} s: the contact points came to rest "
                                                   "and friction can hold the block")
                    break
                start_motion(p, y, t)
                armed[:] = False
                continue
            if code == stepping.ST_BUFFER_FULL:
                status, message = "failed", f"more than max_rows = {max_rows} steps; raise max_rows or dt"
                break
            status = _STATUS[code]
            message = _message(status, event, t, travel_m)
            break

    result = SimulationResult(t=np.concatenate(t_chunks), y=np.concatenate(y_chunks),
                              aux=np.concatenate(a_chunks), status=status, message=message, model=model,
                              method=method, t_start_s=t_start, travel_target_m=travel_m,
                              incipient_converged=converged, incipient_consistency=consistency)
    return result


def _held(model: Model, y0: np.ndarray, method: str, message: str) -> SimulationResult:
    aux = np.zeros(K.N_AUX)
    K.dynamics_ws(0.0, y0, model.kernel_params_cached.copy(), np.empty(K.N_STATE), aux, K.new_workspace())
    return SimulationResult(t=np.zeros(1), y=y0[None, :].copy(), aux=aux[None, :], status="held", message=message,
                            model=model, method=method, t_start_s=math.inf, travel_target_m=0.0,
                            incipient_converged=True, incipient_consistency=1.0)


def _message(status: str, event: int, t: float, travel_m: float) -> str:
    at = f"at t = {t:.4f} s"
    if status == "travel":
        return f"CP1 moved {travel_m * 100:g} cm along e1 {at}"
    if status == "lift_off":
        return f"CP{event} lost contact (its normal reaction reached zero) {at}"
    if status == "mass_centre_outside":
        return f"the mass centre left the contact triangle (seen from above) {at}: the block would tip"
    if status == "left_plane":
        pairs = [(i, j) for i in range(3) for j in range(3) if i != j]
        i, j = pairs[event - 5]
        if t == 0.0:
            return (f"CP{i + 1} starts under FP{j + 1}: the (tilted) planes put it more than 0.1 mm across the line "
                    f"where FP{i + 1} and FP{j + 1} meet, so it cannot rest on FP{i + 1}")
        return f"CP{i + 1} crossed onto FP{j + 1} (left its plane over the line where the planes meet) {at}"
    if status == "time_limit":
        return f"time limit reached {at} before the travel target"
    return f"integration failed {at} (singular contact system or step size underflow)"


def _cp1_x1(y: np.ndarray, p: np.ndarray) -> float:
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    return float(cps[0, 0])


class _user_effects:
    """Install the model's user-written forces as the kernel's callback for the duration of a run."""

    def __init__(self, model: Model):
        self.model = model

    def __enter__(self) -> None:
        effects = self.model.force_effects
        if not effects:
            return
        model = self.model

        def wrench(t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            state = model.block_state(t, y)
            force, moment = np.zeros(3), np.zeros(3)
            for effect in effects:
                f, m = effect.wrench(t, state)
                force += np.asarray(f, dtype=float)
                moment += np.asarray(m, dtype=float)
            return force, moment

        self.previous = K.USER_WRENCH[0]
        K.USER_WRENCH[0] = wrench

    def __exit__(self, *exc: object) -> None:
        if self.model.force_effects:
            K.USER_WRENCH[0] = self.previous

