"""The one driver of the physics: integrate to the next physical ending, deciding arrests on the way.

:func:`drive` is what both users of the model call: :func:`triplanar.simulate.simulate` (a whole test, every
accepted step recorded) and the Gymnasium environment (one control period, nothing recorded). It steps with
:func:`triplanar.stepping.integrate_ws`; when every contact point has nearly stopped (``SLOW``) it asks the
statics whether friction can hold the block (:func:`triplanar.equilibrium.holds`, the LP at the current pose,
thrust and tip offset, with the user effects' wrench at rest) and either ends the stretch ``ARRESTED`` or starts
the block again in the mode :func:`triplanar.stepping.start_motion_ws` finds. Every other ending is returned as
it is (:mod:`triplanar.outcome`): travel, lift-off, mass centre outside, a plane change, the time limit (for the
env: the end of the control period), a failed step, or a full recording buffer (the caller gives a larger one
and calls again).

With ``energy_tol > 0`` a stretch whose energy balance (work in = kinetic + potential + dissipated) is off by
more than ``energy_tol`` joules is redone with adaptive DOPRI5 at the tolerances :data:`FALLBACK_RTOLS` in turn
(a slow slip whose direction turns too fast for a fixed step, or a plain RK4 error near a stop; the env uses it,
``docs/environment.md`` gives the measured accuracy).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numba import njit

from . import equilibrium as E
from . import kernel as K
from . import stepping
from .compiled_cache import drop_if_stale, numba_cache_dir
from .kernel import C_NLOG, C_NLP, C_NREDO, C_NSTART, N_MODE, N_STATE, P_EXTF, P_EXTM, P_USER, S_V, W_COUNT, W_MODES
from .layout import Layout
from .outcome import ARRESTED, SLOW

drop_if_stale(numba_cache_dir(__file__), "driver.*.nb[ic]",
              [Path(module.__file__) for module in (K, stepping, E)]
              + [Path(__file__).parent / name for name in ("outcome.py", "layout.py")],
              "driver.sources.sha256")

# This module's scratch rows, after the steppers' (see the note on scratch memory in triplanar.kernel): where a
# stretch started, for a redo (copies here cost no allocation in the env's hot loop).
WORKSPACE = Layout("DW_", "N_WS_ROWS", [
    ("Y0", 1, "the stretch's initial state"),
    ("MODES0", 1, "its initial stick/slip modes"),
    ("ARMED0", 1, "its initial event arming (5 flags as 0/1)")], start=stepping.N_WS_ROWS)
DW_Y0, DW_MODES0, DW_ARMED0, N_WS_ROWS = WORKSPACE.offsets()
assert WORKSPACE.named_in(globals())


@njit(cache=True, error_model="numpy")
def new_workspace() -> np.ndarray:
    """Scratch memory for the driver and everything below it."""
    return K.allocate_workspace(np.int64(N_WS_ROWS))  # (not a literal: one compiled version for every module)


# DOPRI5 tolerances (rtol; atol = rtol / 1000) of a redo, tried in turn until the energy balance holds; the last is
# taken as it is (over 6000 random-action env periods: 104 needed it, and its balance was then off by <= 8e-11 J).
FALLBACK_RTOLS = (1e-6, 1e-8)


@njit(cache=True, error_model="numpy")
def energy_defect(y0: np.ndarray, y1: np.ndarray, p: np.ndarray, ws: np.ndarray) -> float:
    """Change from ``y0`` to ``y1`` of the energy balance's residual: work in minus (kinetic + potential +
    dissipated), J."""
    work = y1[K.S_WLOAD] - y0[K.S_WLOAD] + y1[K.S_WOTHER] - y0[K.S_WOTHER]
    dissipated = y1[K.S_DTIP] - y0[K.S_DTIP]
    for j in range(3):
        dissipated += y1[K.S_DC + j] - y0[K.S_DC + j]
    potential = p[K.P_MASS] * p[K.P_G] * (y1[K.S_R + 1] - y0[K.S_R + 1])
    return work - (K.kinetic_energy_ws(y1, p, ws) - K.kinetic_energy_ws(y0, p, ws)) - potential - dissipated


@njit(cache=True, inline="always", error_model="numpy")  # (one caller: DEVELOPERS.md, compile time)
def _integrate_checked(t0, y, p, armed, h, opts, rec, row0, ws):
    """:func:`triplanar.stepping.integrate_ws`, redone with DOPRI5 while the energy balance is off (see the module
    docstring). A redo starts again from the stretch's start (state, modes, arming, recorded rows and event log) and
    hands back the stretch's own step ``h``, so a fixed-step caller keeps its step."""
    count = ws[W_COUNT]
    y0, log0 = ws[DW_Y0, :N_STATE], count[C_NLOG]
    y0[:] = y
    ws[DW_MODES0, :N_MODE] = ws[W_MODES, :N_MODE]
    for k in range(5):
        ws[DW_ARMED0, k] = 1.0 if armed[k] else 0.0
    status, event, rows, h_out, t = stepping.integrate_ws(t0, y, p, armed, h, opts, rec, row0, ws)
    for redo_rtol in FALLBACK_RTOLS:
        if opts.energy_tol <= 0.0 or abs(energy_defect(y0, y, p, ws)) <= opts.energy_tol:
            break
        y[:] = y0
        ws[W_MODES, :N_MODE] = ws[DW_MODES0, :N_MODE]
        for k in range(5):
            armed[k] = ws[DW_ARMED0, k] != 0.0
        count[C_NLOG] = log0
        count[C_NREDO] += 1.0
        # (the same field types as the caller's options: integrate_ws is compiled once)
        redo = stepping.StepOptions(np.int64(stepping.METHOD_DOPRI5), redo_rtol, 1e-3 * redo_rtol, opts.t_end,
                                    opts.x1_target, opts.slow_speed, opts.energy_tol)
        status, event, rows, _, t = stepping.integrate_ws(t0, y, p, armed, h, redo, rec, row0, ws)
        h_out = h
    return status, event, rows, h_out, t


@njit(cache=True, error_model="numpy")
def _user_wrench_at_rest(t: float, y: np.ndarray, p: np.ndarray) -> None:
    """The user effects' wrench on the block at pose ``y`` taken at rest (what the statics must balance)."""
    rest = y.copy()
    for i in range(6):
        rest[S_V + i] = 0.0
    K._user_wrench(t, rest, p)


@njit(cache=True, inline="always", error_model="numpy")  # (compiled into the env's control step: no call boundary)
def drive(t: float, y: np.ndarray, p: np.ndarray, armed: np.ndarray, h: float, opts: stepping.StepOptions,
          rec: stepping.Recording, rows: int, ws: np.ndarray):
    """Integrate from (t, y) until a physical ending, ``opts.t_end`` or a full buffer; ``y``, the stick/slip modes (in
    the workspace, :func:`triplanar.kernel.modes_of`) and ``armed`` are updated in place.

    Arguments are :func:`triplanar.stepping.integrate_ws`'s, in the same order: ``opts.energy_tol`` (J, 0: no check)
    is used here, and ``rows`` are the rows already recorded (a continuation writes after them). The block must be
    moving (or started by :func:`triplanar.stepping.start_motion_ws`). Returns (outcome, event index or -1, rows
    recorded, step size, time); the workspace's counters (``kernel.C_*``) add up what the stretch cost.
    """
    count = ws[W_COUNT]
    while True:
        status, event, rows, h, t = _integrate_checked(t, y, p, armed, h, opts, rec, rows, ws)
        if status != SLOW:
            return status, event, rows, h, t
        count[C_NLP] += 1.0
        if p[P_USER] != 0.0:
            _user_wrench_at_rest(t, y, p)
        if E.holds(y, p, K.thrust(t, p), p[P_EXTF:P_EXTF + 3], p[P_EXTM:P_EXTM + 3]):
            stepping.log_outcome(rec.log, count, t, np.int64(-1), np.int64(ARRESTED))  # (the integrator's version)
            return ARRESTED, -1, rows, h, t
        count[C_NSTART] += 1.0
        stepping.start_motion_ws(t, y, p, ws)
        armed[:] = False
