"""A finding recorded, not fixed: a constant sideways pull on the block, a cause outside the library, is named as two
library effects with ``high`` confidence on the project's own generated data.

Data: the stand-in laboratory (``generate_lab_data``), case A (end friction 8 deg) plus a plugin force of 2.5 N along
+e3 at the mass centre, 4 loads x 2 repeats, seed 1; the plugin is unregistered before ``diagnose``, as a cause the
library does not hold. Found 2026-11-28: verdict ``library_effects``, contact friction (phi1 21.4 deg [17.9, 24.8],
phi2 12.9, phi3 9.3 for the drawing's 17, 14 and 11) removing 76 % and a rangefinder drift 10 %, confidence ``high``; baseline
6.28 mm against a repeat scatter of 1.17 mm. The issue's rule is never ``high`` on a wrong answer: when this passes,
remove the xfail."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar import EFFECTS, make_effect
from triplanar.effects import Effect, Parameter
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ModelSpec

pytestmark = pytest.mark.long       # one default diagnose of 8 tests: about 30 CPU s


class SidewaysPull(Effect):
    """A constant force along +e3 at the mass centre (a cable, a leaning frame)."""

    name = "finding_sideways_pull"
    parameters = {"f_N": Parameter(0.0, -10.0, 10.0, "N", "force along +e3")}

    def wrench(self, t, state):
        return np.array([0.0, 0.0, self["f_N"]]), np.zeros(3)


@pytest.mark.xfail(strict=True, reason="a 2.5 N sideways pull is named contact friction plus a rangefinder drift, "
                   "with high confidence (module doc)")
def test_a_sideways_pull_outside_the_library_is_not_named_a_library_effect_with_high_confidence() -> None:
    EFFECTS[SidewaysPull.name] = SidewaysPull
    try:
        tests, _ = generate_lab_data(loads=(27.8, 35.0, 45.0, 55.6), repeats=2, seed=1,
                                     effects=[make_effect("end_friction:phi_deg=8"),
                                              make_effect("finding_sideways_pull:f_N=2.5")])
    finally:
        del EFFECTS[SidewaysPull.name]
    report = Diagnoser(progress=False, executor="serial").fit(tests, ModelSpec(case="A")).report_
    assert report["verdict"] == "outside_library" or report["confidence"] != "high", report["reason"]
