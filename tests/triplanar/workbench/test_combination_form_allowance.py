"""An entry of a combination refitted jointly in a later round keeps the model-form allowance of its own round
(``Effect.form_tolerance_m``; the joint fit cannot measure it, its baseline already holding the entry): on the
calibration's pairs the actuator rise's tau fell outside its interval without it (s1022, s2022, s2051). Hand-made
entries, no simulation."""

from __future__ import annotations

import math

import pytest

from triplanar.effects import REGISTRY
from triplanar.workbench import rules
from triplanar.workbench.combine import _own_allowance, _widened
from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.sweep import CandidateResult


def _entry(effect: str, param: str, value: float, start: float, fit_error_mm: float) -> CandidateResult:
    lo, hi = REGISTRY[effect].parameters[param].fit
    p = FitParameter(effect, param, value, True, lo, hi, start=start, stderr=0.001, ci95=(value - 0.002, value + 0.002),
                     status="fitted")
    return CandidateResult(effect, {param: p}, fit_error_mm, fit_error_mm, 0.8, True, [])


def test_a_jointly_refitted_rise_keeps_its_own_rounds_allowance() -> None:
    rise = _entry("actuator_rise", "tau_s", 0.07, 0.0, 1.0)
    allowance = _own_allowance(rise, 5.0)
    tolerance_mm = rules.form_tolerance_mm("actuator_rise")
    assert tolerance_mm > 0
    # the change of tau that moves the traces by the tolerance, at the rise's own sensitivity in its round
    assert allowance["tau_s"] == pytest.approx(tolerance_mm * 0.07 / math.sqrt(5.0 ** 2 - 1.0 ** 2))
    joint = {"tau_s": (0.071, 0.074)}                    # the later joint fit's interval, missing 0.07
    wide = _widened(joint, "actuator_rise", allowance)
    assert wide["tau_s"][0] == pytest.approx(0.071 - allowance["tau_s"]) and wide["tau_s"][0] < 0.07
    assert wide["tau_s"][1] == pytest.approx(0.074 + allowance["tau_s"])
    assert _widened({"tau_s": (0.0, 0.01)}, "actuator_rise", {"tau_s": 0.5})["tau_s"][0] == 0.0   # physical bound


def test_an_effect_without_its_own_form_tolerance_admits_the_implementations_difference() -> None:
    tip = _entry("tip_offset", "offset_m", 0.005, 0.0, 1.0)
    assert REGISTRY["tip_offset"].form_tolerance_m == 0.0
    assert rules.form_tolerance_mm("tip_offset") == rules.IMPLEMENTATION_TOLERANCE_M * 1e3
    assert rules.form_tolerance_mm("actuator_rise") == REGISTRY["actuator_rise"].form_tolerance_m * 1e3   # the larger
    allowance = _own_allowance(tip, 5.0)["offset_m"]
    assert allowance == pytest.approx(rules.IMPLEMENTATION_TOLERANCE_M * 1e3 * 0.005 / math.sqrt(24.0))
    assert _widened({"offset_m": (0.004, 0.006)}, "tip_offset", {"offset_m": allowance})["offset_m"] == \
        pytest.approx((0.004 - allowance, 0.006 + allowance))
