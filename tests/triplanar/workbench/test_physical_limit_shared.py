"""The fits (``ScaledBox.at_bound``) and the calibration benchmark's re-reading of kept fits ask one question of the
effect, ``Parameter.at_physical_limit``: both read plane_tilt's sideways dip at -0.02 deg as its physical limit and
its other ends as implausible."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from triplanar.effects import REGISTRY
from triplanar.workbench.fitbase import AT_BOUND, ScaledBox

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))

import workbench_calibration as calib


class _Box(ScaledBox):
    def __init__(self, names, lo, hi) -> None:
        self.names, self.lo, self.hi = names, lo, hi


def test_fits_and_the_benchmark_read_a_physical_limit_alike() -> None:
    name = ("plane_tilt", "dip1_e3_deg")
    declared = REGISTRY[name[0]].parameters[name[1]]
    lo, hi = declared.fit
    box = _Box([name], np.array([lo]), np.array([hi]))
    neutral = box.scaled([0.0])
    for value, limit in ((lo, True), (lo + 0.5 * AT_BOUND * (hi - lo), True), (hi, False)):
        assert declared.at_physical_limit(value, AT_BOUND) is limit
        assert calib._at_physical_limit(*name, value) is limit
        assert (box.at_bound(box.scaled([value]), neutral) == ()) is limit
    assert not REGISTRY["end_friction"].parameters["phi_deg"].at_physical_limit(30.0, AT_BOUND)   # no limit declared
