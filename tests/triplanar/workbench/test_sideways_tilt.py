"""``plane_tilt`` fits any direction of FP1's dip: a sideways dip (toward +e3, 90 deg off the drawing's e1) is
recovered (0.5 and 0.8 deg: within the fit range, which ends at 1 deg, where the re-seating reaches 4 mm) by the
default recipe (FP1's two apparent dips, FP2's and FP3's dips free), with its 95 % intervals on the two fitted
components holding the truth: the sideways one at its value, the forward one at zero.

Before, the recipe held FP1's dip direction along e1 and fitted a sideways dip as a forward/backward tilt with an
interval about the wrong quantity. Data: noise 0.2 mm, friction scatter 0.2 deg, 3 loads x 2 repeats, 3-4 cm
(with 2 x 2, four tests for four parameters, the covariance is degenerate).
Run with ``-s`` to print the numbers.
"""

from __future__ import annotations

import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import EffectFit, ModelSpec

pytestmark = pytest.mark.slow  # one four-parameter fit per case: about 20-50 s each


@pytest.mark.parametrize("dip_deg,seed", [(0.5, 211), (0.8, 212)])
def test_a_sideways_dip_of_fp1_is_recovered_with_its_interval(dip_deg, seed):
    truth = make_effect(f"plane_tilt:dip1_deg={dip_deg}deg,dip_dir1_deg=90")
    tests, _ = generate_lab_data(loads=(30.3, 40.0, 50.0), repeats=2, effects=[truth], noise_m=2e-4, scatter_deg=0.2,
                                 stop_range_m=(0.03, 0.04), seed=seed, case="B")
    fit = EffectFit(["plane_tilt"], executor="serial").fit(tests, ModelSpec())
    value, ci = fit.params_["plane_tilt"], fit.ci95_["plane_tilt"]
    print(f"\n[FP1 {dip_deg} deg toward +e3] e3 {value['dip1_e3_deg']:.3f} {ci['dip1_e3_deg']}, "
          f"e1 {value['dip1_e1_deg']:.3f} {ci['dip1_e1_deg']}; error {fit.error_mm_:.3f} mm "
          f"(model as given {fit.baseline_error_mm_:.3f})")
    assert fit.status_["plane_tilt"]["dip1_e3_deg"] == "fitted"
    low, high = ci["dip1_e3_deg"]
    assert 0.0 < low <= dip_deg <= high          # holds the truth, and tells the dip from none
    low, high = ci["dip1_e1_deg"]
    assert low <= 0.0 <= high
    assert fit.error_mm_ < 0.5 * fit.baseline_error_mm_
