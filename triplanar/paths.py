"""Numbers read off contact-point paths, shared by the paper reproduction and the workbench.

A path is an ``(n, 3, 3)`` array: sample, contact point CP1..CP3, coordinate x1..x3 (metres, foundation
frame). Everything here is measured from a **rest position** ``rest`` (3, 3), and a measured path and the
model it is compared with share one: **the block at rest as seated on the foundation the model assumes**
(:attr:`Model.seated_contact_points`, the simulated run's first row). On the drawing's planes this is the
drawing (:attr:`Specimen.contact_points_m`); on tilted planes the re-seated block rests elsewhere (FP1
dipping 0.4 deg sideways moves CP1 0.22 mm along e1 and 1.7 mm vertically).

Why this origin and not each test's own first sample, nor the drawing:

* the drawing, for the data, and the seat, for the model, are two origins: with tilted planes the exact
  model was then compared at the wrong travel (0.21 mm RMS and a spurious oscillation on noise-free data);
* a test's first sample carries the rangefinder noise, which would shift the whole test (with 0.2 mm
  noise, case A's mean distance to the stand-in data grows by up to 0.1 mm), and it would hide a real
  difference between where the block sat and where the model seats it;
* the seat is noise-free, is where the block truly started when the model is right (so the exact model
  leaves only noise), and when the model's planes are wrong the difference of seats stays in the
  discrepancy, as the evidence about the planes it is.

The reader can check that each test starts within a tolerance of the drawing
(``read_measurements(rest_positions=...)``). Instrument effects (``Effect.read``/``unread``) keep the
drawing as the rangefinders' reference, the same in the stand-in laboratory and the workbench.

Quantities:

* **travel**: CP1's displacement along e1 from rest (the paper's Delta q1);
* **heading**: direction of CP1 -> CP2 seen from above, atan2(x3, x1); **rotation**: its change from rest,
  positive counter-clockwise in the paper's overhead plots (the front drifting toward +e3);
* **lateral dilation**: each contact point's x3 minus its x3 at rest;
* distances are horizontal (x1, x3): the paper's figures are overhead views with the vertical suppressed.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from .outcome import Outcome


class Trajectory(Protocol):
    """What :func:`model_at_travel` needs of a simulated test (``SimulationResult`` or a stand-in)."""

    status: Outcome | str  # a SimulationResult's Outcome, or a stand-in's label ("invalid": no run could be made)

    @property
    def t(self) -> np.ndarray: ...

    @property
    def travel(self) -> np.ndarray: ...

    @property
    def contact_points(self) -> np.ndarray: ...


def travel(positions: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(...) CP1's displacement along e1 from ``rest``, m."""
    return positions[..., 0, 0] - rest[0, 0]


def heading_deg(positions: np.ndarray) -> np.ndarray:
    """(...) angle of CP1 -> CP2 seen from above, atan2(x3, x1), degrees, for (..., 3, 3) positions."""
    d = positions[..., 1, :] - positions[..., 0, :]
    return np.degrees(np.arctan2(d[..., 2], d[..., 0]))


def rotation_deg(positions: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(...) turn about e2 from ``rest``, degrees, positive counter-clockwise in the overhead view (CP2
    drifting toward +e3 faster than CP1)."""
    return heading_deg(positions) - heading_deg(rest)


def lateral_dilation(positions: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """(..., 3) lateral (+e3) displacement of each contact point from ``rest``."""
    return positions[..., 2] - rest[:, 2]


def horizontal_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3) horizontal distance between (..., 3, 3) positions, per sample and contact point."""
    return np.hypot(a[..., 0] - b[..., 0], a[..., 2] - b[..., 2])


def ran(result: Trajectory) -> bool:
    """Whether a simulated test moved at all (slid, has two rows, ended ahead of its start)."""
    return result.status is not Outcome.HELD and len(result.t) >= 2 and result.travel[-1] > 0


def model_at_travel(result: Trajectory, travel_m: np.ndarray) -> np.ndarray:
    """(m, 3, 3) model positions at CP1 travels ``travel_m``: below zero, the rest position; beyond the run's
    reach, its last position (what a run that stopped short stands for). The reach is where the run ended: a block
    that slid back at the end (a probe of ``locate`` pushing against the thrust) ends short of its farthest travel,
    and the path by travel is read only up to its end (``Trajectory.time_at_travel``)."""
    travel_m = np.asarray(travel_m, dtype=float)
    if not ran(result):
        return np.repeat(result.contact_points[-1:], len(travel_m), axis=0)
    reach = float(result.travel[-1])
    return result.resample_by_travel(np.clip(travel_m, 0.0, reach))  # type: ignore[attr-defined]
