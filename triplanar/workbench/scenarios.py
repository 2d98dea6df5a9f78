"""The hidden-effect scenarios the workbench is checked against (tests and benchmarks share them).

Every effect ``diagnose`` screens (:func:`~triplanar.workbench.candidates.screened_names`) that has a ``scenario``
(``triplanar/effects.py``): the parameter values a dataset is made with, which a fit must then recover. And two
effects outside the library (never registered, so never a candidate), for data with something the library cannot
name: :class:`ThrustRipple` and :class:`ForceRipple`.
"""

from __future__ import annotations

import math

import numpy as np

from ..effects import REGISTRY, Effect, Parameter
from .candidates import screened_names


def hidden_effects() -> dict[str, tuple[str, dict[str, float]]]:
    """effect -> (the ``--effect`` spec the data are made with, the parameters the fit must recover within 15 %)."""
    scenarios = {name: REGISTRY[name].scenario for name in screened_names()}
    return {name: (f"{name}:" + ",".join(f"{k}={v!r}" for k, v in values.items()), dict(values))
            for name, values in scenarios.items() if values is not None}


#: the registered effects' scenarios when this module is imported (see :func:`hidden_effects`)
HIDDEN_EFFECTS: dict[str, tuple[str, dict[str, float]]] = hidden_effects()


class ThrustRipple(Effect):
    """Outside the library: the thrust oscillates, F_T (1 + frac sin(2 pi f t + phase)), a force along the thrust at
    the mass centre (a worn actuator's screw, a servo hunting)."""

    name = "outside_thrust_ripple"
    parameters = {"frac": Parameter(0.0, 0.0, 1.0, "", "amplitude as a fraction of F_T"),
                  "freq_hz": Parameter(10.0, 0.1, 100.0, "Hz", "frequency"),
                  "phase_rad": Parameter(0.0, -10.0, 10.0, "rad", "phase at t = 0")}

    def wrench(self, t, state):
        force = self["frac"] * state.thrust_N * math.sin(2 * math.pi * self["freq_hz"] * t + self["phase_rad"])
        return force * state.thrust_direction, np.zeros(3)


class ForceRipple(Effect):
    """Outside the library: a steady force ripple amp_N sin(2 pi f t) along e1 at the mass centre (a vibrating
    frame)."""

    name = "outside_force_ripple"
    parameters = {"amp_N": Parameter(0.0, 0.0, 50.0, "N", "amplitude"),
                  "freq_hz": Parameter(6.0, 0.1, 100.0, "Hz", "frequency")}

    def wrench(self, t, state):
        return np.array([self["amp_N"] * math.sin(2 * math.pi * self["freq_hz"] * t), 0.0, 0.0]), np.zeros(3)
