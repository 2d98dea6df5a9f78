"""A finding recorded, not fixed: a viscous drag on the block, a cause outside the library, is named as two library
effects with ``high`` confidence on the project's own generated data.

Data: the stand-in laboratory (``generate_lab_data``), case A (end friction 8 deg) plus a plugin drag of 15 N s/m at the
mass centre (the tutorial's, docs/adding-an-effect.md), 4 loads x 2 repeats, seed 2; the plugin is unregistered before
``diagnose``, as a cause the library does not hold. Found 2026-11-29: verdict ``library_effects`` with confidence
``high``, rate friction (a = 0.20 [0.07, 0.34]) removing 69 % of the error on held-out loads, then contact friction
14 %, together leaving 0.83 mm against a repeat scatter of 0.72 mm (the default diagnosis, as here; without the
model-form step the same on seeds 2 and 5, ``low`` on seed 4, the tutorial's draw). The issue's rule is never ``high``
on a wrong answer: when this passes, remove the xfail."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar import EFFECTS, make_effect
from triplanar.effects import Effect, Parameter
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ModelSpec

pytestmark = pytest.mark.long       # one default diagnose of 8 tests with a Python drag in the data: about 40 CPU s


class Drag(Effect):
    """``-c v`` at the mass centre."""

    name = "finding_viscous_drag"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed of the mass centre")}

    def wrench(self, t, state):
        return -self["c_N_s_m"] * state.velocity, np.zeros(3)


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="a 15 N s/m drag is named rate friction plus contact friction, with high "
                   "confidence (module doc)")
def test_a_drag_outside_the_library_is_not_named_library_effects_with_high_confidence() -> None:
    EFFECTS[Drag.name] = Drag
    try:
        tests, _ = generate_lab_data(loads=(27.8, 35.0, 45.0, 55.6), repeats=2, seed=2,
                                     effects=[make_effect("end_friction:phi_deg=8"),
                                              make_effect("finding_viscous_drag:c_N_s_m=15")])
    finally:
        del EFFECTS[Drag.name]
    model = ModelSpec.from_effects([make_effect("end_friction:phi_deg=8")])
    report = Diagnoser(progress=False, executor="serial").fit(tests, model).report_
    assert report["verdict"] == "outside_library" or report["confidence"] != "high", report["reason"]
