"""Pairs are tried whenever the best single entry leaves a pattern, not only above twice the repeats' scatter.

End friction (8 deg) and a small tip offset (1.5 mm) hidden in the project's own generator's data (loads 32.5-55.6 N
x 2 repeats, seed 3): end friction alone leaves about 1.5 x the repeats' scatter, with a bias common to all tests
(before the rule changed this was ``outside_library``: no combination was tried below 2 x the scatter). Three
candidates, two folds, no model-form step, so that it runs in seconds.
"""

from __future__ import annotations

import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser

pytestmark = pytest.mark.slow  # two rounds of a 3-candidate diagnosis: 14-16 s at load average ~19 (2 cores)

TRUTH = {"end_friction": {"phi_deg": 8.0}, "tip_offset": {"offset_m": 0.0015}}


def test_a_pair_is_found_where_the_best_single_entry_leaves_one_and_a_half_times_the_scatter() -> None:
    tests, record = generate_lab_data(loads=(32.5, 40.0, 47.5, 55.6), repeats=2, seed=3, effects=[
        make_effect("end_friction:phi_deg=8"), make_effect("tip_offset:offset_m=0.0015")])
    assert not record["skipped"]
    diag = Diagnoser(["end_friction", "tip_offset", "rate_friction"], folds=2, progress=False, executor="serial",
                     model_form=False).fit(tests)
    single = diag.best_
    ratio = single.cv_error_mm / diag.repeat_scatter_mm_
    assert single.effect == "end_friction" and 1.2 < ratio < 2.0, ratio     # below the old 2 x threshold
    report = diag.report_
    print("\n", report["verdict"], report["confidence"], report["reason"])
    assert report["verdict"] == "library_effects"
    assert sorted(m["effect"] for m in report["missing_effects"]) == sorted(TRUTH)
    for m in report["missing_effects"]:
        for param, value in TRUTH[m["effect"]].items():
            low, high = m["param_ci95"][param]
            assert low <= value <= high, (m["effect"], m["params"], m["param_ci95"])
    comb = report["combination"]
    # named because it beats the best single entry by more than the uncertainty of the difference
    assert comb["gain_over_single_mm2"] > comb["gain_se_mm2"] > 0
    assert comb["cv_error_mm"] < single.cv_error_mm
