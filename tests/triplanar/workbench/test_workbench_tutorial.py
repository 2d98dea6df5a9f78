"""docs/adding-an-effect.md: run its Python blocks, in order, as a user would."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from triplanar import EFFECTS

pytestmark = pytest.mark.slow  # runs the tutorial's fits: ~1-2 min

DOC = Path(__file__).resolve().parents[3] / "docs" / "adding-an-effect.md"


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
    # section 9: the oscillating thrust with a random phase per test (amplitude and frequency shared), started apart
    # from its neutral amplitude and at the residual's dominant frequency: the error falls, the amplitude is near
    # the truth with an interval that holds it, every test's phase is found
    ripple = namespace["ripple_fit"]
    frac, ci = ripple.params_["thrust_ripple"]["frac"], ripple.ci95_["thrust_ripple"]["frac"]
    assert frac == pytest.approx(0.3, abs=0.05)
    assert ci[0] <= 0.3 <= ci[1] and ci[1] - ci[0] < 0.2
    assert ripple.params_["thrust_ripple"]["freq_hz"] == pytest.approx(10.0, abs=0.5)
    assert ripple.status_["thrust_ripple"]["phase_rad"] == "per_test"
    assert ripple.error_mm_ < 0.5 * ripple.baseline_error_mm_
    truth = {r["test_id"]: r["per_test"]["thrust_ripple"]["phase_rad"] for r in namespace["ripple_truth"]["tests"]}
    fitted = ripple.per_test_["thrust_ripple"]["phase_rad"]
    assert set(fitted) == set(truth)
    misses = [abs((fitted[k] - v + math.pi) % (2 * math.pi) - math.pi) for k, v in truth.items()]
    assert max(misses) < 0.5, misses
    summary = ripple.per_test_summary_["thrust_ripple"]["phase_rad"]
    assert summary["n"] == len(truth) and set(summary) >= {"mean", "sd", "min", "max", "values"}
