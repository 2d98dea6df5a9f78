"""The cost of a Python ``wrench`` effect (the slow path: a callback from the compiled kernel at every right-hand-side
evaluation): one 8 cm trace of case A at 40 N, plain and with the tutorial's two plugin effects
(``docs/adding-an-effect.md``: a viscous drag, a thrust ripple).

Run: ``.venv/bin/python benchmarks/bench_user_effect.py``. Prints the median CPU seconds of a trace (process time,
so a loaded machine disturbs it less than wall time) and the callbacks per trace. One process, one core.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from triplanar import EFFECTS, Effect, Parameter, make_effect, paper_model, register, simulate


class _Drag(Effect):
    name = "bench_viscous_drag"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed of the mass centre")}

    def wrench(self, t, state):
        return -self["c_N_s_m"] * state.velocity, np.zeros(3)


class _Ripple(Effect):
    name = "bench_thrust_ripple"
    parameters = {"frac": Parameter(0.0, 0.0, 0.8, "", "ripple amplitude as a fraction of F_T"),
                  "freq_hz": Parameter(10.0, 1.0, 40.0, "Hz", "ripple frequency")}

    def wrench(self, t, state):
        extra = self["frac"] * state.thrust_N * math.sin(2 * math.pi * self["freq_hz"] * t)
        force = extra * state.thrust_direction
        return force, np.cross(state.load_point - state.position, force)


class _RippleMomentOf(_Ripple):
    name = "bench_thrust_ripple_moment_of"

    def wrench(self, t, state):
        extra = self["frac"] * state.thrust_N * math.sin(2 * math.pi * self["freq_hz"] * t)
        force = extra * state.thrust_direction
        return force, state.moment_of(force, at=state.load_point)


def _cpu_per_trace(model, repeats: int) -> float:
    simulate(model)
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        simulate(model)
        times.append(time.process_time() - t0)
    return statistics.median(times)


def main(repeats: int = 15) -> None:
    for cls in (_Drag, _Ripple, _RippleMomentOf):
        register(cls)
    try:
        for label, effects in [("plain", []), ("viscous drag 15 N s/m", ["bench_viscous_drag:c_N_s_m=15"]),
                               ("thrust ripple, np.cross", ["bench_thrust_ripple:frac=0.3,freq_hz=10"]),
                               ("thrust ripple, moment_of", ["bench_thrust_ripple_moment_of:frac=0.3,freq_hz=10"])]:
            model = paper_model("A", 40.0, effects=[make_effect(e) for e in effects])
            calls = [0]
            if model.force_effects:
                inner = model.user_wrench
                object.__setattr__(model, "user_wrench", lambda t, y: (calls.__setitem__(0, calls[0] + 1), inner(t, y))[1])
            cpu = _cpu_per_trace(model, repeats)
            print(f"{label:28s} {cpu * 1e3:7.1f} ms CPU a trace (median of {repeats}), "
                  f"{calls[0] // (repeats + 1)} callbacks a trace")
    finally:
        for cls in (_Drag, _Ripple, _RippleMomentOf):
            EFFECTS.pop(cls.name, None)


if __name__ == "__main__":
    main()
