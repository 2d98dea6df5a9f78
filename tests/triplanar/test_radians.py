"""Angles given in radians are refused with a hint, like lengths given in millimetres; an explicit override keeps
a true small angle."""

from __future__ import annotations

import re

import pytest

from triplanar import make_effect
from triplanar.effects import EffectError
from triplanar.specimen import SpecimenError, load_toml, reference, to_toml


def _toml_with(tmp_path, old: str, new: str, extra: str = ""):
    text = to_toml(*reference())
    changed = re.sub(old, new, text, count=1)
    assert changed != text
    if extra:
        changed = changed.replace("[specimen]\n", "[specimen]\n" + extra + "\n", 1)
    path = tmp_path / "s.toml"
    path.write_text(changed, encoding="utf-8")
    return path


def test_specimen_friction_angles_in_radians_are_refused_and_the_override_accepts_them(tmp_path) -> None:
    path = _toml_with(tmp_path, r"friction_deg = \[[^\]]*\]", "friction_deg = [0.2967, 0.2443, 0.1920]")
    text = path.read_text()
    text = re.sub(r"tip_friction_deg = [0-9.e+-]+", "tip_friction_deg = 0.1396", text)
    path.write_text(text)
    with pytest.raises(SpecimenError, match=r"friction_deg.*look like radians \(17"):
        load_toml(path)
    path.write_text(text.replace("[specimen]\n", "[specimen]\nallow_small_angles = true\n", 1))
    specimen, _ = load_toml(path)
    assert specimen.friction_deg[0] == pytest.approx(0.2967)



def test_each_angle_field_is_checked_on_its_own(tmp_path) -> None:
    """The contact angles in radians are refused although the tip friction (copied from the reference) is in
    degrees; a tip friction alone in radians is refused too."""
    path = _toml_with(tmp_path, r"friction_deg = \[[^\]]*\]", "friction_deg = [0.2967, 0.2443, 0.1920]")
    assert "tip_friction_deg = 8" in path.read_text()
    with pytest.raises(SpecimenError, match=r"specimen\.friction_deg.*look like radians \(17"):
        load_toml(path)
    path = _toml_with(tmp_path, r"tip_friction_deg = [0-9.e+-]+", "tip_friction_deg = 0.1396")
    with pytest.raises(SpecimenError, match=r"specimen\.tip_friction_deg.*look like radians \(8"):
        load_toml(path)


def test_effect_angles_in_radians_are_refused_unless_marked_as_degrees() -> None:
    with pytest.raises(EffectError, match=r"phi_deg = 0.1396 looks like radians \(8 deg\).*phi_deg=0.1396deg"):
        make_effect("end_friction:phi_deg=0.1396")
    assert make_effect("end_friction:phi_deg=0.1396deg")["phi_deg"] == pytest.approx(0.1396)
    assert make_effect("end_friction:phi_deg=0")["phi_deg"] == 0.0           # zero is no angle at all
    assert make_effect("plane_tilt:dip1_deg=0.3")["dip1_deg"] == 0.3          # small by nature: +-1 deg
    with pytest.raises(EffectError, match="looks like radians"):
        make_effect("contact_friction:phi1_deg=0.29,phi2_deg=0.24,phi3_deg=0.19")


@pytest.mark.parametrize("command", ["diagnose", "fit", "compare"])
def test_the_commands_refuse_radians_by_name_and_write_nothing(tmp_path, capsys, command) -> None:
    """The user's own path: an ``--effect`` angle or a specimen file in radians is refused before any work, with
    the parameter (or file and field) named, and the output folder is not made."""
    from triplanar.cli import main
    from triplanar.labdata import write_lab_data, generate_lab_data
    tests, truth = generate_lab_data(loads=(40.0,), repeats=1, seed=1)
    data = tmp_path / "lab.csv"
    write_lab_data(data, tests, truth)
    extra = ["--add", "end_friction"] if command == "fit" else []
    out = tmp_path / "out"
    code = main([command, str(data), "--effect", "end_friction:phi_deg=0.1396", "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert code != 0 and "phi_deg = 0.1396 looks like radians" in err and not out.exists()
    spec = _toml_with(tmp_path, r"friction_deg = \[[^\]]*\]", "friction_deg = [0.2967, 0.2443, 0.1920]")
    code = main([command, str(data), "--specimen", str(spec), "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert code != 0 and "look like radians" in err and str(spec) in err and not out.exists()
