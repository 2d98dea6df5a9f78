"""docs/adding-an-effect.md: run its Python blocks, in order, as a user would.

Two tests, so that the two halves of the tutorial can run side by side on the two xdist workers: sections 2-8
(the viscous drag: write it, make data, diagnose, fit, a recipe) and section 9 on (the thrust ripple with a
per-test phase), which builds on sections 2-4 only. The second runs the blocks of sections 2-4 as the first does,
and of the blocks of sections 5-8 only their imports (section 9 uses `EffectFit`). Every block runs in one of them.
"""

from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import pytest

from triplanar import EFFECTS

pytestmark = pytest.mark.slow  # runs the tutorial's fits: 25-30 CPU s each

DOC = Path(__file__).resolve().parents[3] / "docs" / "adding-an-effect.md"
RIPPLE_SECTION = 9       # the per-test phase; it builds on sections 2-4 (write, try, data)
SETUP_SECTIONS = 4


def blocks() -> list[tuple[int, str]]:
    """The tutorial's Python blocks, each with the number of the section it is in (a block under an unnumbered
    heading counts with the numbered section before it)."""
    found, section = [], 0
    for part in re.split(r"^(## .*)$", DOC.read_text(encoding="utf-8"), flags=re.M):
        heading = re.match(r"## (\d+)\.", part)
        if heading:
            section = int(heading.group(1))
        found += [(section, code) for code in re.findall(r"```python\n(.*?)```", part, flags=re.S)]
    assert len(found) >= 7 and any(n == RIPPLE_SECTION for n, _ in found)
    return found


def run(code: str, namespace: dict) -> None:
    exec(compile(code, str(DOC), "exec"), namespace)


def imports_only(code: str) -> str:
    tree = ast.parse(code)
    tree.body = [node for node in tree.body if isinstance(node, (ast.Import, ast.ImportFrom))]
    return ast.unparse(tree)


@pytest.fixture
def clean_registry():
    before = dict(EFFECTS)
    yield
    EFFECTS.clear()
    EFFECTS.update(before)


def test_tutorial_code_runs_and_finds_the_new_effect(clean_registry, capsys) -> None:
    namespace: dict = {"__name__": "tutorial"}
    for section, block in blocks():
        if section < RIPPLE_SECTION:
            run(block, namespace)
    print(capsys.readouterr().out)
    assert "viscous_drag" in EFFECTS
    report = namespace["report"]
    assert report["missing_effect"] == "viscous_drag"
    assert report["candidates"][0]["params"]["c_N_s_m"] == pytest.approx(15.0, rel=0.2)
    assert namespace["fit"].error_mm_ < 0.3 * namespace["fit"].baseline_error_mm_
    assert namespace["quick"].candidates_[0].effect in ("viscous_drag", "rate_friction")


def test_tutorial_ripple_with_a_per_test_phase(clean_registry, capsys) -> None:
    """Section 9: the oscillating thrust with a random phase per test (amplitude and frequency shared), started
    apart from its neutral amplitude and at the residual's dominant frequency: the error falls, the amplitude is
    near the truth with an interval that holds it, every test's phase is found."""
    namespace: dict = {"__name__": "tutorial"}
    for section, block in blocks():
        if section <= SETUP_SECTIONS or section >= RIPPLE_SECTION:
            run(block, namespace)
        else:
            run(imports_only(block), namespace)
            assert "report" not in namespace and "fit" not in namespace      # sections 5-8 did not run here
    print(capsys.readouterr().out)
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
