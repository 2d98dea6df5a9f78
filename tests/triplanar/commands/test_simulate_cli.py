"""``triplanar simulate`` as a maker of test data: plugins, uniform samples in the measurement format, the effects in
``--help``, and a bare ``--effect`` that would do nothing refused."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar import read_measurements
from triplanar.cli import main

PLUGIN = '''
import numpy as np
from triplanar import Effect, Parameter, register

@register
class TestDrag(Effect):
    name = "test_drag_simulate"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed")}

    def wrench(self, t, state):
        return -self["c_N_s_m"] * state.velocity, np.zeros(3)
'''


def run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    return code, out, err


def test_sample_rate_writes_uniform_samples_in_the_measurement_format(tmp_path, capsys) -> None:
    out = tmp_path / "t.csv"
    code, text, _ = run(capsys, "simulate", "--case", "B", "--force", "30", "--effect", "end_friction:phi_deg=8",
                        "--out", out, "--sample-rate", "250")
    assert code == 0, text
    (test,) = read_measurements(out)
    assert np.allclose(np.diff(test.t_s), 1 / 250) and test.t_s[0] == 0.0
    assert f"{len(test.t_s)} samples at 250 Hz" in text


def test_a_plugin_effect_makes_data_and_an_instrument_effect_changes_the_record(tmp_path, capsys) -> None:
    plugin = tmp_path / "drag.py"
    plugin.write_text(PLUGIN)
    plain, dragged, read = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    common = ["simulate", "--case", "B", "--force", "40", "--travel", "0.03", "--sample-rate", "200"]
    assert run(capsys, *common, "--out", plain)[0] == 0
    assert run(capsys, *common, "--plugin", plugin, "--effect", "test_drag_simulate:c_N_s_m=20", "--out", dragged)[0] == 0
    assert run(capsys, *common, "--effect", "rangefinder_offset:offset_x3_m=0.002", "--out", read)[0] == 0
    a, b, c = (read_measurements(p)[0] for p in (plain, dragged, read))
    assert b.t_s[-1] > a.t_s[-1]                     # the drag slows the block: more time to the same travel
    assert np.allclose(c.positions[:, :, 2] - a.positions[:, :, 2], 0.002)


def test_help_lists_the_effects_and_a_bare_effect_that_does_nothing_is_refused(tmp_path, capsys) -> None:
    code, text, _ = run(capsys, "simulate", "--help")
    assert code == 0
    for name in ("end_friction", "rate_friction: a (-, default 0", "rangefinder_gain [instrument]"):
        assert name in text
    out = tmp_path / "t.csv"
    code, _, err = run(capsys, "simulate", "--case", "B", "--force", "30", "--effect", "rate_friction", "--out", out)
    assert code == 2 and "--effect rate_friction: without values it changes nothing" in err
    assert "rate_friction:a=0.3" in err and not out.exists()
    assert run(capsys, "simulate", "--case", "B", "--force", "30", "--effect", "end_friction")[0] == 0  # 8 deg: acts


@pytest.mark.parametrize("argv, needle", [(["--sample-rate", "0", "--out", "x.csv"], "--sample-rate 0"),
                                          (["--sample-rate", "200"], "give --out")])
def test_bad_sample_rates_are_refused(tmp_path, capsys, argv, needle) -> None:
    code, _, err = run(capsys, "simulate", "--force", "30", *[a.replace("x.csv", str(tmp_path / "x.csv")) for a in argv])
    assert code == 2 and needle in err
