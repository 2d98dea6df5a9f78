"""docs/adding-an-effect.md: run its Python blocks, in order, as a user would."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from triplanar import EFFECTS

pytestmark = pytest.mark.slow  # runs the tutorial's fits: ~30 s

DOC = Path(__file__).resolve().parents[1] / "docs" / "adding-an-effect.md"


@pytest.fixture
def clean_registry():
    before = dict(EFFECTS)
    yield
    EFFECTS.clear()
    EFFECTS.update(before)


def test_tutorial_code_runs_and_finds_the_new_effect(clean_registry, capsys) -> None:
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 6
    namespace: dict = {"__name__": "tutorial"}
    for block in blocks:
        exec(compile(block, str(DOC), "exec"), namespace)
    printed = capsys.readouterr().out
    print(printed)
    assert "viscous_drag" in EFFECTS
    report = namespace["report"]
    assert report["missing_effect"] == "viscous_drag"
    assert report["candidates"][0]["params"]["c_N_s_m"] == pytest.approx(15.0, rel=0.2)
    assert namespace["fit"].error_mm_ < 0.3 * namespace["fit"].baseline_error_mm_
    assert namespace["quick"].candidates_[0].effect in ("viscous_drag", "rate_friction")
    # section 9: the oscillating thrust, started apart from its neutral amplitude, makes the error fall
    ripple = namespace["ripple_fit"]
    assert ripple.params_["thrust_ripple"]["frac"] == pytest.approx(0.3, abs=0.08)
    assert ripple.status_["thrust_ripple"]["freq_hz"] == "fixed"
    assert ripple.error_mm_ < 0.5 * ripple.baseline_error_mm_
