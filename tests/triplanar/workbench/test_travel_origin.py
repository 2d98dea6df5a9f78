"""One travel origin for data and model: on noise-free traces the exact model leaves only the integrator's error.

The stand-in laboratory (:mod:`triplanar.labdata`) makes noise-free traces with each library effect (its
hidden-effect scenario, and tilted planes that re-seat the block: FP1 dipping sideways and forward, FP3 turned);
``compare`` against that same model measures both paths from the block as seated on the model's foundation
(:mod:`triplanar.paths`) and must leave no more than :data:`INTEGRATOR_FLOOR_MM` (measured: at most 1.3e-5 mm).
Before the origin was one, FP1 dipping 0.4 deg sideways left 0.21 mm and FP1 dipping 0.5 deg back 0.16 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from triplanar.effects import BUILTIN, REGISTRY
from triplanar.labdata import generate_lab_data
from triplanar.model import paper_model
from triplanar.workbench import ModelSpec, compare
from triplanar.workbench.evidence import INTEGRATOR_FLOOR_MM

pytestmark = pytest.mark.slow  # 16 small datasets (about 5 s) and one small diagnosis (about a minute)

TILTS = [{"dip1_deg": 0.4, "dip_dir1_deg": 90.0},      # FP1 dipping sideways (re-seats CP1 0.22 mm along e1)
         {"dip1_deg": -0.5},                            # FP1 dipping back toward -e1
         {"dip3_deg": 2.0, "dip_dir3_deg": 10.0}]       # FP3 steeper and turned
CASES = [(name, dict(REGISTRY[name].scenario)) for name in BUILTIN if REGISTRY[name].scenario] \
    + [("plane_tilt", tilt) for tilt in TILTS]


@pytest.mark.parametrize("name,values", CASES, ids=[f"{n}-{i}" for i, (n, _) in enumerate(CASES)])
def test_exact_model_leaves_only_the_integrators_error(name, values):
    effect = REGISTRY[name](**values)
    tests, _ = generate_lab_data(loads=(35.0, 50.0), repeats=1, effects=[effect], noise_m=0.0, scatter_deg=0.0,
                                 stop_range_m=(0.02, 0.02), seed=1, case="B")
    cmp = compare(tests, ModelSpec.from_effects([effect]))
    assert len(cmp.discrepancies) == 2
    assert cmp.error_mm < INTEGRATOR_FLOOR_MM, (repr(effect), cmp.error_mm)
    assert cmp.pattern().startswith("within the noise"), cmp.pattern()


def test_the_origin_is_the_seated_block():
    """The tilted planes move the seat off the drawing (else the test above would test nothing), and the seat
    is the simulated run's first row."""
    from triplanar.simulate import simulate
    model = paper_model("B", 40.0, effects=[REGISTRY["plane_tilt"](**TILTS[0])])
    shift = model.seated_contact_points - model.specimen.contact_points_m
    assert abs(shift[0, 0]) > 1e-4               # CP1 re-seated 0.22 mm along e1
    run = simulate(model, travel_m=0.002)
    np.testing.assert_allclose(run.contact_points[0], model.seated_contact_points, atol=1e-12)
    flat = paper_model("B", 40.0)
    np.testing.assert_array_equal(flat.seated_contact_points, flat.specimen.contact_points_m)


def test_diagnose_given_the_exact_tilt_finds_nothing_missing():
    """Given the exact truth (FP1 dipping 0.4 deg sideways) on noise-free data, diagnose says ``none_missing``:
    before, with two origins, it named ``time_offset``; with one origin but patterns read into the integrator's
    error, ``outside_library`` ("periodic at 48.1 Hz", "systematic" at 1e-6 mm)."""
    from triplanar.workbench import Diagnoser
    truth = REGISTRY["plane_tilt"](**TILTS[0])
    tests, _ = generate_lab_data(loads=(30.3, 40.0, 50.0), repeats=2, effects=[truth], noise_m=0.0, scatter_deg=0.0,
                                 stop_range_m=(0.03, 0.04), seed=3, case="B")
    report = Diagnoser(folds=2, progress=False, candidates=["time_offset", "plane_tilt", "end_friction"]).fit(
        tests, ModelSpec.from_effects([truth])).report_
    assert report["verdict"] == "none_missing", report["reason"]
    assert report["time_domain"]["dominant_frequency_hz"] is None
