"""Path metrics shared by the paper reproduction and the workbench (triplanar/paths.py)."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar import MeasuredTest, paper_model, reference, simulate
from triplanar.paths import heading_deg, horizontal_distance, lateral_dilation, model_at_travel, rotation_deg, travel
from triplanar.workbench.discrepancy import discrepancy

REST = reference()[0].contact_points_m


def test_quantities_from_rest() -> None:
    turn = np.radians(10.0)
    c, s = np.cos(turn), np.sin(turn)
    # turn counter-clockwise seen from above (x1 right, x3 up) about CP1, then move 2 cm forward
    rot = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    moved = (REST - REST[0]) @ rot.T + REST[0] + np.array([0.02, 0.0, 0.0])
    path = np.stack([REST, moved])
    assert travel(path, REST) == pytest.approx([0.0, 0.02])
    assert rotation_deg(path, REST) == pytest.approx([0.0, 10.0])
    assert heading_deg(moved) - heading_deg(REST) == pytest.approx(10.0)
    np.testing.assert_allclose(lateral_dilation(moved, REST), moved[:, 2] - REST[:, 2])
    assert lateral_dilation(path, REST).shape == (2, 3)
    np.testing.assert_allclose(horizontal_distance(path, path[::-1])[1], np.hypot(*(moved - REST)[:, ::2].T))


def test_model_at_travel_clamps_to_rest_and_to_the_reach() -> None:
    run = simulate(paper_model("A", 40.0), travel_m=0.03)
    out = model_at_travel(run, np.array([-0.001, 0.0, 0.03, 0.05]))
    np.testing.assert_allclose(out[0], run.contact_points[0], atol=1e-12)
    np.testing.assert_allclose(out[1], run.contact_points[0], atol=1e-12)
    np.testing.assert_allclose(out[3], out[2], atol=0)
    np.testing.assert_allclose(out[2], run.contact_points[-1], atol=1e-9)


def test_a_noisy_first_sample_does_not_shift_the_measured_travel() -> None:
    """Measured paths are measured from the specimen's rest, not from their own first sample."""
    run = simulate(paper_model("A", 40.0), travel_m=0.05)
    clean = run.to_measured("clean")
    positions = clean.positions.copy()
    positions[0] += np.array([0.3e-3, 0.0, -0.2e-3])  # rangefinder noise on the first sample only
    noisy = MeasuredTest("noisy", 40.0, positions, clean.t_s)
    model = simulate(paper_model("A", 40.0), travel_m=0.055)
    a, b = discrepancy(clean, model), discrepancy(noisy, model)
    np.testing.assert_array_equal(a.travel_m[1:], b.travel_m[1:])
    np.testing.assert_array_equal(a.dilation_error_mm, b.dilation_error_mm)
    assert a.rotation_error_deg == b.rotation_error_deg
    assert a.error_mm < 1e-3


def test_model_at_travel_reads_a_run_that_slid_back_up_to_where_it_ended() -> None:
    """A run whose block ends short of its farthest travel (its last row a few rows back along the path, as a
    ``locate`` probe pushing against the thrust can end): travels beyond where it ended give its last position
    instead of raising (the calibration's held-out report, seed 11037, 2026-11-29)."""
    from dataclasses import replace
    run = simulate(paper_model("A", 40.0), travel_m=0.03)
    rows = [*range(len(run.t)), len(run.t) - 4]
    back = replace(run, t=np.append(run.t, 2 * run.t[-1] - run.t[-2]), y=run.y[rows], dydt=run.dydt[rows],
                   aux=run.aux[rows])
    assert back.travel[-1] < np.max(back.travel)
    out = model_at_travel(back, np.array([0.0, back.travel[-1], np.max(back.travel), 0.05]))
    np.testing.assert_allclose(out[2], out[1], atol=0)
    np.testing.assert_allclose(out[3], out[1], atol=0)
