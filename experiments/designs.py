"""Actuator designs of the bench study's sweep: tip, stage bandwidth, latency, rangefinder noise."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Design:
    """Actuator hardware: tip friction, stage bandwidth, latency, rangefinder noise."""

    name: str
    tip_friction_deg: float
    stage_bandwidth_hz: float
    latency_s: float
    sensor_noise_m: float

    def env_kwargs(self) -> dict[str, Any]:
        return {"stage_bandwidth_hz": self.stage_bandwidth_hz, "latency_s": self.latency_s,
                "sensor_noise_m": self.sensor_noise_m}

    def demand(self) -> int:
        """Hardware demand, an ordinal sum (0 = least demanding): tip steel 0, PTFE 1, rolling 2; stage 5 Hz 0,
        20 Hz 1, 100 Hz 2, ideal 3; latency 10 ms 0, 0 ms 1; noise 1 mm 0, 0.2 mm 1, 0.05 mm 2."""
        tip = {8.0: 0, 3.0: 1, 0.5: 2}[self.tip_friction_deg]
        stage = {5.0: 0, 20.0: 1, 100.0: 2}.get(self.stage_bandwidth_hz, 3)
        latency = 0 if self.latency_s > 0 else 1
        noise = {1e-3: 0, 2e-4: 1, 5e-5: 2}[self.sensor_noise_m]
        return tip + stage + latency + noise


DESIGNS = (
    Design("steel_slow_noisy", 8.0, 5.0, 0.01, 1e-3),
    Design("steel_lab", 8.0, 20.0, 0.01, 2e-4),
    Design("steel_ideal", 8.0, math.inf, 0.0, 5e-5),
    Design("ptfe_slow", 3.0, 5.0, 0.01, 2e-4),
    Design("ptfe_lab", 3.0, 20.0, 0.01, 2e-4),
    Design("ptfe_lab_noisy", 3.0, 20.0, 0.01, 1e-3),
    Design("ptfe_fast", 3.0, 100.0, 0.0, 2e-4),
    Design("ptfe_ideal", 3.0, math.inf, 0.0, 5e-5),
    Design("rolling_slow_noisy", 0.5, 5.0, 0.01, 1e-3),
    Design("rolling_slow", 0.5, 5.0, 0.01, 2e-4),
    Design("rolling_lab", 0.5, 20.0, 0.01, 2e-4),
    Design("rolling_lab_precise", 0.5, 20.0, 0.01, 5e-5),
    Design("rolling_fast", 0.5, 100.0, 0.0, 2e-4),
    Design("rolling_ideal", 0.5, math.inf, 0.0, 5e-5),
)


def design_by_name(name: str) -> Design:
    """A design of :data:`DESIGNS` by name (an unknown name is refused with the list)."""
    for design in DESIGNS:
        if design.name == name:
            return design
    raise ValueError(f"unknown design {name!r}; choose from {[d.name for d in DESIGNS]}")
