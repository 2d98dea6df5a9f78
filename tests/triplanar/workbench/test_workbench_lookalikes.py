"""Look-alike explanations and the experiment that would decide between them, on data from the project's own
generator: cohesion (0.35 N per contact) hidden in case-A data, diagnosed against case A (8 tests, seed 1)."""

from __future__ import annotations

import json

import pytest

from triplanar import make_effect, write_measurements
from triplanar.cli import main
from triplanar.labdata import generate_lab_data

pytestmark = pytest.mark.slow  # a diagnosis of 12 candidates and the experiment's simulations: about 10 s


def test_cohesion_and_contact_friction_are_reported_indistinguishable_with_a_deciding_load(tmp_path, capsys) -> None:
    tests, truth = generate_lab_data(loads=(27.8, 35.0, 45.0, 55.6), repeats=2, seed=1, effects=[
        make_effect("end_friction:phi_deg=8"), make_effect("cohesion:c_N=0.35")])
    assert not truth["skipped"]
    data = tmp_path / "cohesion.csv"
    write_measurements(data, tests)
    out = tmp_path / "out"
    code = main(["diagnose", str(data), "--effect", "end_friction:phi_deg=8", "--folds", "2", "--executor", "serial",
                 "--no-progress", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    report = json.loads((out / "diagnose.json").read_text())
    named = report["missing_effect"]
    assert {named, *report["indistinguishable_from"]} >= {"cohesion", "contact_friction"}
    assert report["confidence"] != "high"
    (exp,) = [e for e in report["deciding_experiments"] if "contact_friction" in e["between"]]
    best = exp["best"]
    assert best is not None and best["repeats"] >= 1
    # the proposed load is where the two fitted models differ most relative to the scatter
    assert best["difference_mm"] == max(r["difference_mm"] for r in exp["rows"] if r["difference_mm"] is not None)
    assert f"test at {best['load_N']:g} N" in printed and "indistinguishable from the named entry" in printed
    assert (out / "deciding.png").stat().st_size > 0
    # the verdict names the group, with the shear test that decides (issue: not a winner among twins)
    (group,) = [g for g in report["lookalike_groups"] if g["source"] == "effects"]
    assert group["members"] == [named, *report["indistinguishable_from"]]
    assert exp["sentence"] in group["deciding_measurement"]
