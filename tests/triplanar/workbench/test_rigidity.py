"""Instrument or specimen, from rigidity (``triplanar/workbench/rigidity.py``): the three measured contact points keep
their mutual distances unless a position channel misreads.

Data: the project's generator (its kernel's traces, 0.2 mm noise), 2 loads x 2 repeats, made once for the module.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.measurement import MeasuredTest
from triplanar.specimen import reference
from triplanar.workbench.rigidity import ALPHA, rigidity

REST = reference()[0].contact_points_m


@functools.lru_cache(maxsize=None)
def _lab(*specs: str) -> list[MeasuredTest]:
    tests, truth = generate_lab_data(loads=(35.0, 50.0), repeats=2, noise_m=2e-4, seed=5,
                                     effects=[make_effect(s) for s in specs])
    assert not truth["skipped"]
    return tests


def _spoiled(tests: list[MeasuredTest], point: int, axis: int, gain: float = 1.0, offset_m: float = 0.0):
    """The tests with one channel (a point's axis) reading ``gain`` x its displacement from rest, plus ``offset_m``."""
    out = []
    for t in tests:
        x = np.array(t.positions)
        x[:, point, axis] = REST[point, axis] + (x[:, point, axis] - REST[point, axis]) * gain + offset_m
        out.append(MeasuredTest(t.test_id, t.shear_force_N, x, t.t_s))
    return out


def test_a_gain_on_one_rangefinder_channel_is_an_instrument():
    # CP2's x1 channel reads 5 % too much of its displacement: CP1-CP2 (along x1) stretches with travel
    result = rigidity(_spoiled(_lab("end_friction:phi_deg=8"), point=1, axis=0, gain=1.05))
    assert result.kind == "instrument"
    assert result.pattern == "grows with travel"
    assert "CP1-CP2" in result.broken and "CP1-CP3" not in result.broken   # CP1-CP3 does not involve CP2
    pair = next(p for p in result.pairs if p.pair == "CP1-CP2")
    travel_mm = 1e3 * np.median([t.travel[-1] for t in _lab("end_friction:phi_deg=8")])
    assert pair.change_mm == pytest.approx(0.05 * travel_mm, rel=0.25)     # 5 % of the travel, in mm
    assert result.statistic < ALPHA and "rangefinder gain or drift" in result.sentence


def test_the_library_rangefinder_gain_along_x1_is_seen_as_the_block_turns():
    # the same gain on the three points stretches the triangle along x1: the diagonal CP1-CP3 changes as it turns
    # (case B: the block turns by degrees; with the tip's end friction it nearly translates, and the shared gain
    # changes CP1-CP3 by less than the noise shows: measured 0.06 +- 0.06 mm here)
    result = rigidity(_lab("rangefinder_gain:gain_x1=1.2"))
    assert result.kind == "instrument" and "CP1-CP3" in result.broken


def test_a_specimen_effect_keeps_the_block_rigid():
    for specs in (("end_friction:phi_deg=8",), ("contact_friction:phi1_deg=20",)):
        result = rigidity(_lab(*specs))
        assert result.kind == "specimen_or_load", (specs, result.sentence)
        assert result.statistic >= ALPHA and not result.broken


def test_clean_data_and_a_load_cell_gain_are_not_instruments_to_rigidity():
    assert rigidity(_lab()).kind != "instrument"
    loaded = rigidity(_lab("end_friction:phi_deg=8", "load_cell_gain:gain=0.9"))
    assert loaded.kind == "specimen_or_load"          # rigidity cannot see it, and says which errors it cannot see
    assert "load-cell gain" in loaded.sentence


def test_an_offset_on_one_channel_or_a_point_off_the_drawing_is_a_constant_difference():
    offset = rigidity(_spoiled(_lab("end_friction:phi_deg=8"), point=2, axis=2, offset_m=1.5e-3))
    assert offset.kind == "instrument_or_drawing" and set(offset.broken) == {"CP1-CP3", "CP2-CP3"}
    drawn = rigidity(_lab("end_friction:phi_deg=8", "specimen:cp3_x1_m=0.003"))
    assert drawn.kind == "instrument_or_drawing" and "measuring the block's contact points" in drawn.sentence


def test_missing_vertical_coordinates_and_short_tests_are_handled():
    tests = _lab("end_friction:phi_deg=8")
    no_x2 = []
    for t in tests:
        x = np.array(t.positions)
        x[:, :, 1] = np.nan                   # no vertical in the file: no pair has its six coordinates
        no_x2.append(MeasuredTest(t.test_id, t.shear_force_N, x, t.t_s))
    result = rigidity(no_x2)
    assert result.kind == "undecided" and result.n_tests == 0
    assert result.as_json()["detectable_mm"] is None
    some = [MeasuredTest(t.test_id, t.shear_force_N, np.where(np.arange(t.n_samples)[:, None, None] % 2 == 0,
                                                               t.positions, np.nan), t.t_s) for t in tests]
    assert rigidity(some).kind == "specimen_or_load"          # every other sample without coordinates: still read
    short = [MeasuredTest(t.test_id, t.shear_force_N, t.positions[:5], t.t_s[:5]) for t in tests]
    assert rigidity(short).kind == "undecided"
    with pytest.raises(ValueError, match="rest"):
        rigidity(tests, rest=np.zeros((2, 3)))


def test_diagnose_reports_rigidity_and_physics_is_not_named_high_on_an_instrument_fault():
    from dataclasses import replace

    from triplanar.workbench import Diagnoser
    from triplanar.workbench import rules
    from triplanar.workbench.results import DiagnosisResult
    diag = Diagnoser(["end_friction", "rangefinder_gain"], folds=2, progress=False, model_form=False, audit=False,
                     combine=False, executor="serial").fit(_lab("rangefinder_gain:gain_x1=1.2"))
    field = diag.report_["rigidity"]
    assert field["kind"] == "instrument" and "CP1-CP3" in field["broken"] and field["threshold"] == ALPHA
    assert "rigidity (instrument): " in DiagnosisResult.of(diag).report()
    # an instrument effect named: the rules make the same verdict without the rigidity test
    assert rules.decide(replace(diag.evidence_, rigidity=None)) == diag.decision_
    # physics named with confidence high on a block whose contact points' distances change: capped at low
    physics = Diagnoser(["end_friction", "time_offset"], folds=2, progress=False, model_form=False, audit=False,
                        combine=False, executor="serial").fit(_lab("end_friction:phi_deg=8"))
    assert physics.decision_.confidence == "high" and physics.evidence_.rigidity.kind != "instrument"
    capped = rules.decide(replace(physics.evidence_, rigidity=diag.evidence_.rigidity))
    assert capped.kind == physics.decision_.kind and capped.effects[0].effect == "end_friction"
    assert capped.confidence == "low" and all(e.confidence == "low" for e in capped.effects)
    assert any(r.rule == "rigidity.instrument" for r in capped.reasons)
