"""Numbers the paper reproduction reads off contact-point paths: distance between two sets of paths at equal
travel, and where measured tests are at a given travel (the quantities the paper discusses in sections 5.1-5.5).

Travel, lateral dilation, rotation and horizontal distance are defined once, in :mod:`triplanar.paths`
(a simulated path from its first row, a measured one from ``rest_positions``, the specimen's rest position: on
the paper's foundation the block seats exactly there, so both share one origin as :mod:`triplanar.paths` asks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measurement import MeasuredTest
from ..paths import horizontal_distance, lateral_dilation, model_at_travel, rotation_deg, travel
from ..result import SimulationResult

__all__ = ["PathDistance", "at_travel", "data_vs_model", "horizontal_distance", "lateral_dilation",
           "measured_peak_speed", "measured_travel", "model_vs_model", "peak_speed", "rotation_deg", "travel_grid"]


@dataclass(frozen=True)
class PathDistance:
    """Horizontal distance between two sets of paths, per contact point, metres."""

    mean_m: np.ndarray     # (3,) CP1..CP3
    max_m: np.ndarray      # (3,)
    n_samples: int         # points compared
    n_beyond: int = 0      # measured samples beyond the model's travel (not compared)

    def as_dict(self, scale: float = 1.0) -> dict[str, object]:
        """JSON-ready, in millimetres (divided by ``scale`` for a scaled specimen)."""
        return {"mean_mm": (self.mean_m / scale * 1e3).tolist(), "max_mm": (self.max_m / scale * 1e3).tolist(),
                "n_samples": self.n_samples, "n_beyond": self.n_beyond}


def travel_grid(result_a: SimulationResult, result_b: SimulationResult, n: int = 161) -> np.ndarray:
    """Travels both simulations reached, evenly spaced from rest."""
    return np.linspace(0.0, min(result_a.travel[-1], result_b.travel[-1]), n)


def model_vs_model(result_a: SimulationResult, result_b: SimulationResult, n: int = 161) -> PathDistance:
    """Distance between two simulated paths at equal travel, over the travel both reached."""
    grid = travel_grid(result_a, result_b, n)
    d = horizontal_distance(result_a.resample_by_travel(grid), result_b.resample_by_travel(grid))
    return PathDistance(d.mean(axis=0), d.max(axis=0), len(grid))


def measured_travel(test: MeasuredTest, rest_positions: np.ndarray) -> np.ndarray:
    """CP1's measured travel along e1 from the specimen's rest position (m) at every sample."""
    return travel(test.positions, rest_positions)


def data_vs_model(tests: list[MeasuredTest], result: SimulationResult, rest_positions: np.ndarray) -> PathDistance:
    """Distance from every measured sample to the model's contact points at the same travel.

    Samples pooled over ``tests``; a measured travel below zero (noise at rest) is compared with the rest
    position; samples beyond the model's final travel (model stopped earlier) are not compared and counted.
    """
    dists, beyond = [], 0
    reach = result.travel[-1]
    for test in tests:
        s = measured_travel(test, rest_positions)
        inside = s <= reach
        beyond += int((~inside).sum())
        if inside.any():
            dists.append(horizontal_distance(test.positions[inside], model_at_travel(result, s[inside])))
    if not dists:
        nan = np.full(3, np.nan)
        return PathDistance(nan, nan, 0, beyond)
    d = np.concatenate(dists)
    return PathDistance(d.mean(axis=0), d.max(axis=0), len(d), beyond)


def at_travel(test: MeasuredTest, travel_m: float, rest_positions: np.ndarray) -> np.ndarray | None:
    """(3, 3) measured positions where CP1's travel first reaches ``travel_m`` (linear between the two
    samples around it), or None if the test stopped short of it."""
    s = measured_travel(test, rest_positions)
    after = np.flatnonzero(s >= travel_m)
    if not after.size:
        return None
    i = int(after[0])
    if i == 0:
        return test.positions[0]
    w = (travel_m - s[i - 1]) / (s[i] - s[i - 1])
    return (1 - w) * test.positions[i - 1] + w * test.positions[i]


def peak_speed(result: SimulationResult) -> float:
    """Largest contact-point speed in a simulated test (m/s)."""
    return float(np.linalg.norm(result.contact_velocities, axis=2).max())


def measured_peak_speed(test: MeasuredTest, window: int = 4) -> float:
    """Largest horizontal CP1 speed estimated from a measured test by differences over ``window``
    sampling intervals (noise sd ~ sqrt(2) * noise / (window * dt)); NaN without time."""
    if test.t_s is None or test.n_samples <= window:
        return float("nan")
    p = test.positions[:, 0, :]
    dx = np.hypot(p[window:, 0] - p[:-window, 0], p[window:, 2] - p[:-window, 2])
    return float((dx / (test.t_s[window:] - test.t_s[:-window])).max())
