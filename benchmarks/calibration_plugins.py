"""Causes outside the library for the workbench's calibration set, written as plugin effects (``docs/adding-an-effect.md``).

None is registered while a calibration set is made or diagnosed: they are what the library does not hold, so
``diagnose`` must not have them as candidates or model-form alternatives. ``--plugin benchmarks/calibration_plugins.py``
registers them (``register_all``) for a user who wants to try them as candidates. Each acts through ``wrench(t,
state)`` (a force at the mass centre and a moment about it, world axes, SI); the independent laboratory
(``benchmarks/independent_lab.py``) evaluates them on its own kinematics.
"""

from __future__ import annotations

import math

import numpy as np

from triplanar.effects import Effect, Parameter, register

ZERO = np.zeros(3)


class OutsideViscousDrag(Effect):
    """A viscous drag ``-c v`` at the mass centre (an oil film, a damper on the frame)."""

    name = "outside_viscous_drag"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed of the mass centre")}

    def wrench(self, t, state):
        return -self["c_N_s_m"] * np.asarray(state.velocity), ZERO


class OutsideQuadraticDrag(Effect):
    """A drag ``-k |v| v`` at the mass centre (a turbulent film, a brush seal)."""

    name = "outside_quadratic_drag"
    parameters = {"k_N_s2_m2": Parameter(0.0, 0.0, 200.0, "N s^2/m^2", "drag per squared speed")}

    def wrench(self, t, state):
        v = np.asarray(state.velocity)
        return -self["k_N_s2_m2"] * float(np.linalg.norm(v)) * v, ZERO


class OutsideThrustRipple(Effect):
    """The actuator's force ripples: ``+A sin(2 pi f t + phase)`` along e1 at the mass centre (a pump's pulsation)."""

    name = "outside_thrust_ripple"
    parameters = {"amplitude_N": Parameter(0.0, 0.0, 10.0, "N", "ripple amplitude"),
                  "frequency_hz": Parameter(8.0, 0.5, 50.0, "Hz", "ripple frequency"),
                  "phase_rad": Parameter(0.0, -math.pi, math.pi, "rad", "phase at t = 0")}

    def wrench(self, t, state):
        a = self["amplitude_N"] * math.sin(2 * math.pi * self["frequency_hz"] * t + self["phase_rad"])
        return np.array([a, 0.0, 0.0]), ZERO


class OutsideLateralPull(Effect):
    """A constant sideways force along e3 at the mass centre (a cable of the instrumentation pulling)."""

    name = "outside_lateral_pull"
    parameters = {"force_N": Parameter(0.0, -10.0, 10.0, "N", "force along e3")}

    def wrench(self, t, state):
        return np.array([0.0, 0.0, self["force_N"]]), ZERO


class OutsideTravelHardening(Effect):
    """A resistance growing with the distance slid, ``-b s v/|v|`` at the mass centre (``s``: the mass centre's
    travel along e1 since rest; debris gathering in front of the contacts)."""

    name = "outside_travel_hardening"
    parameters = {"b_N_m": Parameter(0.0, 0.0, 200.0, "N/m", "resistance per metre slid"),
                  "x0_m": Parameter(0.0, -1.0, 1.0, "m", "the mass centre's x1 at rest", free=False)}

    def wrench(self, t, state):
        v = np.asarray(state.velocity)
        speed = float(np.linalg.norm(v))
        travel = max(0.0, float(state.position[0]) - self["x0_m"])
        if speed < 1e-9:
            return ZERO, ZERO
        return -self["b_N_m"] * travel * v / speed, ZERO


OUTSIDE: dict[str, type[Effect]] = {cls.name: cls for cls in (OutsideViscousDrag, OutsideQuadraticDrag,
                                                               OutsideThrustRipple, OutsideLateralPull,
                                                               OutsideTravelHardening)}


def register_all() -> None:
    """Register every effect here (as ``--plugin`` would); the calibration itself never calls this."""
    for cls in OUTSIDE.values():
        register(cls)
