"""A given number of the specimen freed by name (``fit --free NAME``) is recovered within its interval; bad names
and ranges are refused naming the number, before anything is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from triplanar.cli import main
from triplanar.effects import REGISTRY, EffectError
from triplanar.labdata import generate_lab_data
from triplanar.specimen_numbers import NUMBERS
from triplanar.workbench import ModelSpec
from triplanar.workbench.candidates import candidate_library
from triplanar.workbench.fit import EffectFit
from triplanar.workbench.given import specimen_candidate

ROOT = Path(__file__).resolve().parents[3]
END_FRICTION = REGISTRY["end_friction"](phi_deg=8.0)


@pytest.mark.slow   # a small dataset and one fit: about 2.5 s
def test_a_moved_contact_point_is_recovered_within_its_interval():
    # CP3 machined 3 mm forward of its drawing; the kernel's own traces with 0.2 mm noise, 3 loads x 1 test
    truth = 0.003
    tests, _ = generate_lab_data(loads=(35.0, 45.0, 55.0), repeats=1, noise_m=2e-4, scatter_deg=0.0, seed=3,
                                 effects=[END_FRICTION, REGISTRY["specimen"](cp3_x1_m=truth)],
                                 stop_range_m=(0.03, 0.03), case="B")
    fit = EffectFit([specimen_candidate({"cp3_x1_m": None})]).fit(tests, ModelSpec.from_effects([END_FRICTION]))
    p = fit.parameters_["specimen"]["cp3_x1_m"]
    assert p.status == "fitted" and p.ci95[0] <= truth <= p.ci95[1], (p.value, p.ci95)
    assert p.ci95[1] - p.ci95[0] < 0.002           # pinned well inside the drawing's +-5 mm
    assert fit.error_mm_ < 0.5 * fit.baseline_error_mm_


def test_the_given_numbers_are_not_default_candidates():
    assert "specimen" not in {c.effect for c in candidate_library()}


def test_a_negative_mass_bound_is_refused_naming_the_number():
    with pytest.raises(EffectError, match=r"mass_kg = -1 kg is outside the physical range"):
        specimen_candidate({"mass_kg": (-1.0, 6.0)})


def test_a_contact_point_off_its_plane_is_refused_naming_the_number():
    with pytest.raises(EffectError, match=r"cp2_x2_m: a contact point's height is not free: it lies on its plane FP2"):
        specimen_candidate({"cp2_x2_m": None})


def test_a_range_where_the_specimen_fails_its_check_is_refused_naming_the_number():
    # CP3 moved 30 cm forward: the mass centre no longer projects inside the contact triangle
    with pytest.raises(EffectError, match=r"cp3_x1_m = 0.3 m does not describe a physical specimen: mass_centre_m"):
        specimen_candidate({"cp3_x1_m": (0.0, 0.3)})


def test_a_pad_moved_under_another_plane_is_refused_and_the_default_range_stops_short_of_it():
    """The drawing's CP2 rests on the line where FP2 meets FP1: 3 mm aft it would lie under FP1 (found on the
    independent calibration's data, where such a block was drawn and could not start in the kernel)."""
    with pytest.raises(EffectError, match=r"cp2_x1_m = -0.003 m puts the block off its planes: CP2 starts under FP1"):
        specimen_candidate({"cp2_x1_m": (-0.003, 0.003)})
    (free,) = specimen_candidate({"cp2_x1_m": None}).recipe
    assert -0.001 < free.min < 0.0 and free.max == pytest.approx(0.005)     # the drawing's +-5 mm, cut on one side


@pytest.mark.parametrize("free", ["bogus_kg", "mass_kg=-2:6", "cp1_x2_m"])
def test_the_cli_refuses_a_bad_free_and_writes_nothing(tmp_path, capsys, free):
    out = tmp_path / "out"
    code = main(["fit", str(ROOT / "data" / "lab_traces.csv"), "--free", free, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    name = free.split("=")[0]
    assert name in err
    if free == "bogus_kg":
        assert all(n in err for n in NUMBERS), err
