"""The calibration set's detectability criterion (benchmarks/calibration_detectability.py), from the truth alone: a
clean dataset has D ~ 0 (the integrator's error) and expects none_missing; a large cause expects its kind's verdict; a pair whose second
effect barely moves the traces expects only the first. Two loads keep it cheap."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))

import calibration_detectability as cd
import workbench_calibration as calib

pytestmark = pytest.mark.slow  # a few kernel simulations per case: seconds


def _cfg(label: str, seed: int, **change) -> dict:
    return {**calib.settings(label, seed), "loads_N": [40.0, 55.6], **change}


def test_clean_dataset_expects_nothing() -> None:
    det = cd.detectability(_cfg("clean_case_b", 1003))
    assert det["ratio"] < 1e-3 and det["expected_verdict"] == "none_missing"   # the integrator's error only


def test_large_cause_shows_and_a_tiny_pair_member_is_not_expected() -> None:
    det = cd.detectability(_cfg("end_friction", 1000))
    assert det["ratio"] > 3 and det["expected_verdict"] == "library_effect"
    pair = _cfg("pair_end_friction_tip_offset", 1002,
                truth=[["end_friction", {"phi_deg": 8.0}], ["tip_offset", {"offset_m": 1e-5}]])
    det = cd.detectability(pair)
    assert det["components"]["tip_offset"] < cd.DETECTABLE <= det["components"]["end_friction"]
    assert det["expected_verdict"] == "library_effect" and det["expected_effects"] == ["end_friction"]
