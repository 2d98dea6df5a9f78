"""The result objects of fit and diagnose: their JSON and their printout."""

from __future__ import annotations

import json

from triplanar.workbench.results import DiagnosisResult, FitResult, FitStep, format_param


def _steps() -> list[FitStep]:
    given = FitStep("given", None, {}, {}, 14.6, {27.8: 33.0, 55.6: 6.0})
    added = FitStep("fit", "end_friction", {"end_friction": {"phi_deg": 8.12}}, {"end_friction": {"phi_deg": 0.14}},
                    0.55, {27.8: 1.2, 55.6: 0.4}, {"end_friction": {"phi_deg": [7.81, 8.43]}},
                    {"end_friction": {"phi_deg": "fitted"}})
    chosen = FitStep("selection", "tip_offset", {"end_friction": {"phi_deg": 8.2}, "tip_offset": {"offset_m": 0.001}},
                     {"end_friction": {"phi_deg": 0.2}, "tip_offset": {"offset_m": 0.0003}}, 0.5, {27.8: 1.0},
                     {"end_friction": {"phi_deg": [7.8, 8.6]}, "tip_offset": {"offset_m": None}},
                     confidence="low", reason="barely better")
    return [given, added, chosen]


def test_fit_result_json_has_each_kind_of_step_and_survives_json() -> None:
    result = FitResult("case B", "case A", _steps(), "nothing left", {"specimen": {}, "foundation_normals": []})
    data = json.loads(json.dumps(result.to_json()))
    assert list(data) == ["model", "fitted_model", "steps", "stop_reason", "drawing"]
    given, added, chosen = data["steps"]
    assert given == {"added": None, "effects": {}, "param_stderr": {}, "error_mm": 14.6,
                     "error_by_load_mm": {"27.8": 33.0, "55.6": 6.0}}
    assert added["param_ci95"] == {"end_friction": {"phi_deg": [7.81, 8.43]}} and added["refitted"] is False
    assert "per_test" not in added and added["at_bound"] == []
    assert chosen["confidence"] == "low" and chosen["reason"] == "barely better" and "param_status" not in chosen


def test_fit_result_report_says_each_step_and_why_selection_stopped() -> None:
    text = FitResult("case B", "case A", _steps(), "nothing left", {}).report().splitlines()
    assert text[0] == "model: case B"
    assert text[1].startswith("  model as given") and "14.600 mm" in text[1]
    assert "+ end_friction" in text[2] and "phi_deg = 8.12 [7.81, 8.43]" in text[2]
    assert "offset_m = 0.001 (no interval)" in text[3]
    assert text[4].strip() == "confidence low: barely better"
    assert text[-1] == "forward selection stopped: nothing left"


def test_format_param_says_why_a_parameter_has_no_interval() -> None:
    assert format_param("phi", 8.0, None, "fixed") == "phi = 8 (fixed)"
    assert format_param("phi", 0.0, None, "not_moved") == "phi = 0 (never left its start)"
    assert format_param("phi", 30.0, [29.0, 30.0], "at_bound") == "phi = 30 [29, 30] (at the edge of its range)"


def test_diagnosis_result_prints_the_verdict_of_its_report() -> None:
    report = {"model": "case B", "n_tests": 4, "baseline_error_mm": 2.0, "repeat_scatter_mm": 0.5,
              "candidates": [{"effect": "end_friction", "params": {"phi_deg": 8.0},
                              "param_ci95": {"phi_deg": [7.0, 9.0]}, "param_status": {"phi_deg": "fitted"},
                              "cv_error_mm": 0.6, "improvement": 0.7, "plausible": True, "at_bound": []}],
              "missing_effect": "end_friction", "verdict": "library_effect", "confidence": "high",
              "reason": "it explains the data", "seconds": 1.0}
    result = DiagnosisResult(report, [], None, "case B", None)
    assert result.to_json() is report
    assert (result.verdict, result.missing_effect, result.confidence) == ("library_effect", "end_friction", "high")
    text = result.report()
    assert "end_friction" in text and "phi_deg = 8 [7, 9]" in text
    assert "verdict: library_effect   missing effect: end_friction   confidence: high" in text
