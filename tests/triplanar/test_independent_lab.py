"""The calibration set's independent laboratory (benchmarks/independent_lab.py: the natural-coordinates reference,
its own RK4) follows the compiled kernel's paths where both apply: case B and a tip offset, sharp Coulomb law,
no noise. Short runs (55.6 N, 2 cm of travel) keep it cheap; ``benchmarks/workbench_calibration.py check`` runs every
extension to 6 cm."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from independent_lab import LabPhysics, hermite, run_test

from triplanar import make_effect, paper_model, simulate
from triplanar.specimen import reference


@pytest.mark.slow  # two RK4 runs in numpy per case (about 1 s each of CPU)
@pytest.mark.parametrize("effect, extra", [(None, {}), ("tip_offset:offset_m=0.005", {"tip_offset_m": 0.005})])
def test_the_independent_lab_follows_the_kernel_to_a_hundredth_of_a_millimetre(effect, extra) -> None:
    spec, fnd = reference()
    kernel = simulate(paper_model("B", 55.6, effects=[make_effect(effect)] if effect else []), travel_m=0.02)
    lab = LabPhysics(spec, tuple((p.dip_deg, p.dip_direction_deg) for p in fnd.planes), 55.6, spec.friction_deg,
                     **extra)
    t, P, V, status = run_test(lab, 0.02)
    assert status == "travel"
    tq = np.linspace(0.0, min(t[-1], kernel.t[-1]), 50)
    distance = np.linalg.norm(hermite(t, P, V, tq) - kernel.contact_points_at(tq), axis=2)
    assert distance.max() < 1e-5
    # and the comparison can fail: a 1 deg larger CP1 friction moves the paths by more than that
    other = LabPhysics(spec, lab.planes, 55.6, (18.0, 14.0, 11.0), **extra)
    t2, P2, V2, _ = run_test(other, 0.02)
    tq2 = np.linspace(0.0, min(t2[-1], kernel.t[-1]), 50)
    assert np.linalg.norm(hermite(t2, P2, V2, tq2) - kernel.contact_points_at(tq2), axis=2).max() > 1e-4
