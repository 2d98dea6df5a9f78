"""The compare / diagnose / fit commands, and bad input."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from triplanar import MeasuredTest, write_measurements
from triplanar.cli import main
from triplanar.labdata import generate_lab_data
from triplanar.specimen import reference, to_toml


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    tests, _ = generate_lab_data(loads=(27.8, 40.0, 55.6), repeats=2, seed=5)
    path = tmp_path_factory.mktemp("wb") / "lab.csv"
    write_measurements(path, tests)
    return path


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_compare_writes_table_summary_and_figures(data, tmp_path, capsys) -> None:
    code, out, err = run(capsys, "compare", data, "--out", tmp_path)
    assert code == 0, err
    for name in ("compare.csv", "summary.txt", "overhead.png", "residuals.png", "error_map.png"):
        assert (tmp_path / name).stat().st_size > 0
    rows = list(csv.DictReader(open(tmp_path / "compare.csv")))
    assert len(rows) == 6 * 3
    assert {"mean_distance_mm", "max_distance_mm", "lateral_dilation_error_mm", "rotation_error_deg",
            "arrival_time_error_s"} <= set(rows[0])
    assert "RMS discrepancy" in out and "pattern:" in out and "CP1" in out


def test_compare_with_the_right_effect_is_close(data, tmp_path, capsys) -> None:
    code, out, _ = run(capsys, "compare", data, "--effect", "end_friction:phi_deg=8", "--out", tmp_path, "--no-plots")
    assert code == 0
    rows = list(csv.DictReader(open(tmp_path / "compare.csv")))
    assert max(float(r["mean_distance_mm"]) for r in rows) < 3.0


def test_diagnose_json_report(data, tmp_path, capsys) -> None:
    report_path = tmp_path / "r.json"
    code, out, err = run(capsys, "diagnose", data, "--candidates", "end_friction,rate_friction", "--json", report_path,
                         "--out", tmp_path / "d", "--no-progress", "--workers", "1")
    assert code == 0, err
    report = json.loads(report_path.read_text())
    assert report["missing_effect"] == "end_friction"
    assert report["confidence"] in ("high", "low")
    assert isinstance(report["baseline_error_mm"], float)
    best = report["candidates"][0]
    assert best["effect"] == "end_friction" and 0.7 < best["improvement"] <= 1.0
    assert set(best["params"]) == set(best["param_stderr"]) == {"phi_deg"}
    assert (tmp_path / "d" / "diagnose.json").exists() and (tmp_path / "d" / "diagnose.png").exists()
    assert "missing effect: end_friction" in out


def test_fit_add_and_error_fall(data, tmp_path, capsys) -> None:
    code, out, err = run(capsys, "fit", data, "--add", "end_friction", "--out", tmp_path, "--workers", "1")
    assert code == 0, err
    result = json.loads((tmp_path / "fit.json").read_text())
    steps = result["steps"]
    assert [s["added"] for s in steps] == [None, "end_friction"]
    assert steps[1]["effects"]["end_friction"]["phi_deg"] == pytest.approx(8.0, rel=0.15)
    assert steps[1]["error_mm"] < 0.2 * steps[0]["error_mm"]
    for name in ("error_fall.png", "overhead.png", "residuals.png", "deviations.png"):
        assert (tmp_path / name).stat().st_size > 0


@pytest.mark.parametrize("command, options", [
    ("compare", []),
    ("diagnose", ["--candidates", "end_friction", "--folds", "2", "--workers", "1", "--no-progress"]),
    ("fit", ["--add", "end_friction", "--workers", "1"]),
])
def test_no_plots_writes_the_report_only_and_removes_an_earlier_runs_figures(data, tmp_path, capsys, command,
                                                                              options) -> None:
    from triplanar.commands import compare, diagnose, fit
    figures = {"compare": compare.FIGURES, "diagnose": diagnose.FIGURES, "fit": fit.FIGURES}[command]
    for name in figures:
        (tmp_path / name).write_bytes(b"an earlier run's figure")
    code, out, err = run(capsys, command, data, *options, "--out", tmp_path, "--no-plots")
    assert code == 0, err
    assert not list(tmp_path.glob("*.png"))     # none left to disagree with the new report
    report = {"compare": "compare.csv", "diagnose": "diagnose.json", "fit": "fit.json"}[command]
    assert (tmp_path / report).stat().st_size > 0
    wrote = out.strip().splitlines()[-1]
    assert wrote.startswith("wrote ") and report in wrote and ".png" not in wrote


# -- bad input -----------------------------------------------------------------------------------------

def rewrite(src: Path, dst: Path, edit) -> Path:
    rows = list(csv.reader(open(src)))
    edit(rows)
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return dst


def test_missing_column_names_row_and_column(data, tmp_path, capsys) -> None:
    def drop(rows):
        i = rows[0].index("cp2_x3_m")
        for r in rows:
            del r[i]
    bad = rewrite(data, tmp_path / "bad.csv", drop)
    code, _, err = run(capsys, "compare", bad, "--out", tmp_path / "o")
    assert code == 2 and "row 1" in err and "cp2_x3_m" in err and "missing required column" in err


def test_non_numeric_value_names_row_and_column(data, tmp_path, capsys) -> None:
    def spoil(rows):
        rows[7][rows[0].index("cp1_x3_m")] = "abc"
    bad = rewrite(data, tmp_path / "bad.csv", spoil)
    code, _, err = run(capsys, "diagnose", bad, "--out", tmp_path / "o")
    assert code == 2 and "row 8" in err and "cp1_x3_m" in err


def test_millimetres_are_refused_with_a_hint(data, tmp_path, capsys) -> None:
    def mm(rows):
        rows[3][rows[0].index("cp3_x1_m")] = "12.5"
    bad = rewrite(data, tmp_path / "bad.csv", mm)
    code, _, err = run(capsys, "fit", bad, "--add", "end_friction", "--out", tmp_path / "o")
    assert code == 2 and "row 4" in err and "millimetres" in err


def test_specimen_that_contradicts_the_data(data, tmp_path, capsys) -> None:
    specimen, foundation = reference()
    other = replace(specimen, contact_points_m=np.array([[-0.14, 0.0, 0.30], [0.0, 0.0, 0.30], [0.0, 0.0, 0.0]]))
    toml = tmp_path / "other.toml"
    toml.write_text(to_toml(other, foundation))
    code, _, err = run(capsys, "compare", data, "--specimen", toml, "--out", tmp_path / "o")
    assert code == 2 and "row 2" in err and "rest position" in err and "wrong specimen" in err


def test_test_below_the_sliding_threshold_is_reported_per_test(data, tmp_path, capsys) -> None:
    from triplanar import read_measurements
    tests = read_measurements(data)
    low = MeasuredTest("too-weak", 12.0, tests[0].positions, tests[0].t_s)
    path = tmp_path / "low.csv"
    write_measurements(path, tests[2:4] + [low])
    code, out, err = run(capsys, "compare", path, "--out", tmp_path / "o", "--no-plots")
    assert code == 0, err
    rows = [r for r in csv.DictReader(open(tmp_path / "o" / "compare.csv")) if r["test_id"] == "too-weak"]
    assert rows and rows[0]["model_status"] == "held" and "never slides" in rows[0]["note"]
    assert "12 N the model never slides" in out


@pytest.mark.parametrize("argv, needle", [
    (["compare", "--effect", "bogus"], "unknown effect 'bogus'; known effects: actuator_rise, "),  # sorted
    (["fit", "--add", "bogus"], "unknown effect 'bogus'"),
    (["diagnose", "--candidates", "end_friction,bogus"], "unknown effect 'bogus'"),
    (["compare", "--effect", "end_friction:phi_deg=99"], "outside [0.0, 40.0]"),
    (["compare", "--effect", "end_friction:angle=3"], "has no parameter 'angle'"),
    (["fit"], "nothing to fit"),
    (["compare", "--plugin", "no_such_module_xyz"], "no_such_module_xyz"),
])
def test_bad_options_are_refused_with_the_known_names(data, tmp_path, capsys, argv, needle) -> None:
    code, _, err = run(capsys, argv[0], data, *argv[1:], "--out", tmp_path / "o")
    assert code == 2 and needle in err


# -- the report contract, refits, fixed parameters, plots ----------------------------------------------

@pytest.mark.slow
def test_diagnose_refits_a_wrong_given_parameter_and_fit_frees_it(data, tmp_path, capsys) -> None:
    code, out, err = run(capsys, "diagnose", data, "--effect", "end_friction:phi_deg=4", "--candidates",
                         "rate_friction", "--out", tmp_path / "d", "--no-progress", "--workers", "1")
    assert code == 0, err
    report = json.loads((tmp_path / "d" / "diagnose.json").read_text())
    assert report["verdict"] == "refit_given_effect" and report["missing_effect"] is None
    (refit,) = report["refits"]
    assert refit["given"] == 4.0 and refit["fitted"] == pytest.approx(8.0, abs=0.8)
    assert "(refit)" in out and "verdict: refit_given_effect" in out
    assert report["model"] == "case A (end friction, phi_EF = 4 deg)"
    assert (tmp_path / "d" / "time_residuals.png").stat().st_size > 0
    code, out, err = run(capsys, "fit", data, "--effect", "end_friction:phi_deg=4", "--add", "end_friction",
                         "--add", "rate_friction", "--out", tmp_path / "f", "--workers", "1", "--no-plots")
    assert code == 0, err
    steps = json.loads((tmp_path / "f" / "fit.json").read_text())["steps"]
    assert steps[1]["refitted"] and steps[1]["given"] == {"phi_deg": 4.0}
    assert steps[2]["param_status"]["rate_friction"]["v0_m_s"] == "fixed"
    assert "v0_m_s = 0.05 (fixed)" in out and "nan" not in out
    assert "refit end_friction" in out      # (the fit's figures: test_fit_add_and_error_fall)
