"""A fitted value at an end of its range that the effect declares a physical limit is not implausible; at any other
end it is (issue 32: plane_tilt's sideways dip resting at -0.02 deg, just above the step where CP2 leaves FP1)."""

from __future__ import annotations

import numpy as np

from triplanar.effects import REGISTRY
from triplanar.workbench.fitbase import ScaledBox


class _Box(ScaledBox):
    """The fit's scaled box over plane_tilt's two FP1 components (a joint fit's problem is one of these)."""

    def __init__(self, names, lo, hi) -> None:
        self.names, self.lo, self.hi = names, lo, hi


def _box() -> ScaledBox:
    names = [("plane_tilt", "dip1_e1_deg"), ("plane_tilt", "dip1_e3_deg")]
    lo = np.array([REGISTRY[e].parameters[p].fit[0] for e, p in names])
    hi = np.array([REGISTRY[e].parameters[p].fit[1] for e, p in names])
    return _Box(names, lo, hi)


def test_sideways_dip_at_its_physical_limit_is_plausible() -> None:
    box = _box()
    neutral = box.scaled([0.0, 0.0])
    at_limit = box.scaled([0.3, -0.02])           # dip1_e3 at its lower end: the left_plane step
    assert box.at_bound(at_limit, neutral) == ()


def test_other_ends_stay_implausible() -> None:
    box = _box()
    neutral = box.scaled([0.0, 0.0])
    assert box.at_bound(box.scaled([-1.0, 0.3]), neutral) == ("plane_tilt.dip1_e1_deg",)   # not declared a limit
    assert box.at_bound(box.scaled([0.3, 1.0]), neutral) == ("plane_tilt.dip1_e3_deg",)    # its upper end either
    assert box.at_bound(neutral, neutral) == ()                                              # at rest: no effect
