"""The instruments' given numbers open to question (``triplanar.instrument_numbers``): freed by name like the
specimen's (``fit --free time_base_rate``), recovered within their interval, audited by ``diagnose`` with the
measurement outside the shear test that decides; bad names and ranges refused naming the number, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest

from triplanar import make_effect
from triplanar.cli import main
from triplanar.effects import REGISTRY
from triplanar.instrument_numbers import INSTRUMENT_NUMBERS
from triplanar.labdata import generate_lab_data
from triplanar.specimen_numbers import NUMBERS
from triplanar.workbench import Diagnoser, ModelSpec
from triplanar.workbench.fit import EffectFit
from triplanar.workbench.given import free_candidates
from triplanar.workbench.given_audit import EFFECT_MEASUREMENT
from triplanar.workbench.spec import spec_with_values

ROOT = Path(__file__).resolve().parents[3]
CASE_A = spec_with_values(ModelSpec(), "end_friction", {"phi_deg": 8.0})


def clock_lab(rate: float) -> list:
    """The kernel's traces of case A with the logger's clock running ``rate`` x true time, 4 loads x 2."""
    tests, truth = generate_lab_data(loads=(27.8, 35.0, 45.0, 55.6), repeats=2, seed=1,
                                     effects=[make_effect("end_friction:phi_deg=8"),
                                              make_effect(f"time_base:rate={rate}")])
    assert not truth["skipped"]
    return tests


@pytest.mark.parametrize("name", INSTRUMENT_NUMBERS)
def test_each_instrument_number_is_an_instrument_effects_parameter_from_its_identity(name: str) -> None:
    number = INSTRUMENT_NUMBERS[name]
    effect = REGISTRY[number.effect]
    assert effect.acts_on == "instrument" and number.param in effect.parameters
    (cand,) = free_candidates({name: None})
    assert cand.effect == number.effect and cand.free == (number.param,)
    assert cand.start[number.param] == effect.parameters[number.param].neutral_value == number.given
    assert cand.bounds[number.param] == effect.parameters[number.param].fit       # the calibration's tolerance


@pytest.mark.slow   # one fit of 8 tests: about 3 s
def test_a_freed_clock_is_recovered_within_its_interval() -> None:
    tests = clock_lab(1.05)
    fit = EffectFit(free_candidates({"time_base_rate": None})).fit(tests, CASE_A)
    p = fit.parameters_["time_base"]["rate"]
    assert p.status == "fitted" and p.ci95[0] <= 1.05 <= p.ci95[1], (p.value, p.ci95)
    assert p.ci95[1] - p.ci95[0] < 0.02
    assert fit.error_mm_ < 0.5 * fit.baseline_error_mm_


@pytest.mark.slow   # one diagnosis with the audit: about 5 s
def test_a_clock_off_is_reported_by_the_audit_with_the_measurement_that_decides() -> None:
    """The clock 8 % fast, diagnosed with the default candidates (the time base is not one): the audit of the
    instruments' numbers says the given time base is probably 1.08, with the reference clock as what decides."""
    report = Diagnoser(progress=False, executor="serial").fit(clock_lab(1.08), CASE_A).report_
    (audited,) = [a for a in report["given_numbers"] if a["name"] == "time_base_rate"]
    assert audited["ci95"][0] <= 1.08 <= audited["ci95"][1], audited
    assert "your given time_base_rate = 1 is probably" in report["reason"]
    assert f"to decide: {EFFECT_MEASUREMENT['time_base']}" in report["reason"]
    assert audited["deciding_measurement"] == EFFECT_MEASUREMENT["time_base"]
    assert report["confidence"] != "high"       # the clock explains within MARGIN of (here: better than) the named


def test_a_bad_free_name_lists_every_freeable_number_and_writes_nothing(tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code = main(["fit", str(ROOT / "data" / "lab_traces.csv"), "--free", "clock_rate", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "clock_rate" in err and all(n in err for n in [*NUMBERS, *INSTRUMENT_NUMBERS]), err


@pytest.mark.parametrize("free", ["time_base_rate=0:1.1", "time_base_rate=-1:1.1"])
def test_a_time_base_range_at_or_below_zero_is_refused_naming_it(tmp_path, capsys, free: str) -> None:
    out = tmp_path / "out"
    code = main(["fit", str(ROOT / "data" / "lab_traces.csv"), "--free", free, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    low = free.split("=")[1].split(":")[0]
    assert f"time_base_rate = {low} is outside the physical range" in err, err


def test_an_instrument_freed_and_added_at_once_is_refused(tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code = main(["fit", str(ROOT / "data" / "lab_traces.csv"), "--add", "load_cell_gain", "--free", "load_cell_gain",
                 "--out", str(out)])
    assert code == 2 and not out.exists()
    assert "load_cell_gain" in capsys.readouterr().err
