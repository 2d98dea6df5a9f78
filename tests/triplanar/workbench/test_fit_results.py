"""The result objects of fit and diagnose: their JSON and their printout."""

from __future__ import annotations

import json

from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.results import DiagnosisResult, FitResult, FitStep, format_param
from triplanar.workbench.select import SelectionStep


def _fitted(effect: str, name: str, value: float, stderr: float, ci: tuple[float, float] | None,
            lo: float, hi: float) -> FitParameter:
    return FitParameter(effect, name, value, True, lo, hi, value, stderr=stderr, ci95=ci,
                        status="fitted" if ci else "degenerate")


def _steps() -> list[FitStep]:
    given = FitStep("given", None, {}, 14.6, {27.8: 33.0, 55.6: 6.0})
    phi = _fitted("end_friction", "phi_deg", 8.12, 0.14, (7.81, 8.43), 0.0, 15.0)
    added = FitStep("fit", "end_friction", {"end_friction": {"phi_deg": phi}}, 0.55, {27.8: 1.2, 55.6: 0.4})
    chosen = FitStep("selection", "tip_offset",
                     {"end_friction": {"phi_deg": _fitted("end_friction", "phi_deg", 8.2, 0.2, (7.8, 8.6), 0.0, 15.0)},
                      "tip_offset": {"offset_m": _fitted("tip_offset", "offset_m", 0.001, 0.0003, None, -0.008, 0.008)}},
                     0.5, {27.8: 1.0}, confidence="low", reason="barely better")
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
    assert added["effects"] == {"end_friction": {"phi_deg": 8.12}}
    assert added["param_stderr"] == {"end_friction": {"phi_deg": 0.14}}
    assert added["param_status"] == {"end_friction": {"phi_deg": "fitted"}}
    assert chosen["param_ci95"] == {"end_friction": {"phi_deg": [7.8, 8.6]}, "tip_offset": {"offset_m": None}}
    assert chosen["param_stderr"] == {"end_friction": {"phi_deg": 0.2}, "tip_offset": {"offset_m": 0.0003}}


def test_a_step_reports_held_per_test_and_profiled_parameters_in_the_report_form() -> None:
    held = FitParameter("end_friction", "phi_deg", 8.0, False, 0.0, 45.0, status="fixed")
    phi = FitParameter("end_friction", "phi_deg", 8.0, True, 0.0, 15.0, 0.0, stderr=0.1, ci95=(7.8, 8.2),
                       status="fitted", profile_ci95=(7.7, 8.3))
    offset = FitParameter("tip_offset", "offset_m", 0.0, True, -0.008, 0.008, per_test=True, status="per_test",
                          per_test_values={"t1": 0.001, "t2": 0.003})
    step = FitStep("fit", "end_friction", {"end_friction": {"phi_deg": phi}}, 0.5, {27.8: 0.5},
                   intervals=("profile",)).to_json()
    assert step["param_profile_ci95"] == {"end_friction": {"phi_deg": [7.7, 8.3]}}
    assert "param_profile_ci95" not in FitStep("fit", "end_friction", {"end_friction": {"phi_deg": phi}}, 0.5,
                                               {}).to_json()
    both = FitStep("fit", "tip_offset", {"end_friction": {"phi_deg": held}, "tip_offset": {"offset_m": offset}},
                   0.4, {})
    data = both.to_json()
    assert data["effects"] == {"end_friction": {"phi_deg": 8.0}, "tip_offset": {}}     # per-test: no shared value
    assert data["param_status"] == {"end_friction": {"phi_deg": "fixed"}, "tip_offset": {"offset_m": "per_test"}}
    assert data["param_ci95"] == {"end_friction": {}, "tip_offset": {"offset_m": None}}
    assert data["per_test"]["tip_offset"]["offset_m"]["n"] == 2
    assert data["per_test"]["tip_offset"]["offset_m"]["mean"] == 0.002
    assert "phi_deg = 8 (fixed)" in both.report() and "offset_m per test (2 values" in both.report()


def test_selection_step_zero_holds_the_effects_it_starts_from() -> None:
    from triplanar.workbench.select import held_parameters
    step = SelectionStep(None, held_parameters({"end_friction": {"phi_deg": 8.0}}), 1.0, {}).as_json()
    assert step["effects"] == {"end_friction": {"phi_deg": 8.0}}
    assert step["param_stderr"] == {} and step["param_ci95"] == {}


def test_fit_result_report_says_each_step_and_why_selection_stopped() -> None:
    text = FitResult("case B", "case A", _steps(), "nothing left", {}).report().splitlines()
    assert text[0] == "model: case B"
    assert text[1].startswith("  model as given") and "14.600 mm" in text[1]
    assert "+ end_friction" in text[2] and "phi_deg = 8.12 [7.81, 8.43]" in text[2]
    assert "offset_m = 0.001 (the data do not pin it (degenerate covariance))" in text[3]   # its status says why
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
