"""docs/adding-an-effect.md: run its Python blocks, in order, as a user would, and check that each prints what the
doc shows beside it (the indented lines right after the block; none: it prints nothing).

Three tests. Two run in `make test`, side by side on the two xdist workers: sections 2-8 (the viscous drag: write
it, make data, diagnose with it among the candidates, fit, a recipe) and section 9 on (the thrust ripple with a
per-test phase), which builds on sections 2-4 only. The third, marked ``long`` (`make test-slow`), is the loop of
sections 5-6 as a user meets it: the library alone diagnosed, the cause located, the drag fitted; its diagnosis
tries the library's entries in combination, about 25 CPU s. Of the blocks a test leaves out it runs only the
imports (later blocks use them). Every block runs in one of them.
"""

from __future__ import annotations

import ast
import contextlib
import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from triplanar import EFFECTS
from triplanar.workbench.rules import EXPLAINED_FACTOR

pytestmark = pytest.mark.slow  # runs the tutorial's fits: 10-30 CPU s each

DOC = Path(__file__).resolve().parents[3] / "docs" / "adding-an-effect.md"
SETUP_SECTIONS = 4       # write, try, data: every test runs them
LOOP_SECTIONS = (5, 6)   # the library alone and where the cause is (section 5), the drag fitted (section 6)
LIBRARY_ALONE = "### The library alone, and where the cause is"
RIPPLE_SECTION = 9       # the per-test phase; it builds on sections 2-4 (write, try, data)
TRUE_DRAG_N_S_M = 15.0   # section 4's laboratory
NUMBER = re.compile(r"([-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?)")


@dataclass(frozen=True)
class Block:
    """One Python block: its section's number (a block under an unnumbered heading counts with the numbered section
    before it), the heading it is under (``##`` or ``###``), its code, and what the doc shows it prints."""

    section: int
    heading: str
    code: str
    shown: str


def blocks() -> list[Block]:
    found, section = [], 0
    for heading, body in _parts(DOC.read_text(encoding="utf-8")):
        numbered = re.match(r"## (\d+)\.", heading)
        section = int(numbered.group(1)) if numbered else section
        for code, shown in re.findall(r"```python\n(.*?)```\n\n?((?:    [^\n]*\n)*)", body, flags=re.S):
            found.append(Block(section, heading, code, "\n".join(line[4:] for line in shown.splitlines())))
    assert len(found) >= 9 and any(b.section == RIPPLE_SECTION for b in found)
    assert any(b.heading == LIBRARY_ALONE for b in found)
    return found


def _parts(text: str) -> list[tuple[str, str]]:
    pieces = re.split(r"^(##+ .*)$", text, flags=re.M)
    return [("", pieces[0])] + list(zip(pieces[1::2], pieces[2::2]))


def same_print(printed: str, shown: str) -> bool:
    """The same words and layout, each number within one unit of the last digit shown (a rounding that falls the
    other way on another machine)."""
    a, b = NUMBER.split(printed.strip()), NUMBER.split(shown.strip())
    if len(a) != len(b):
        return False
    for k, (p, s) in enumerate(zip(a, b)):
        if k % 2 == 0:
            if [x.rstrip() for x in p.split("\n")] != [x.rstrip() for x in s.split("\n")]:
                return False
            continue
        mantissa, _, exponent = s.lower().partition("e")
        decimals = len(mantissa.partition(".")[2])
        if abs(float(p) - float(s)) > 1.000001 * 10.0 ** (int(exponent or 0) - decimals):
            return False
    return True


def run(block: Block, namespace: dict) -> None:
    """Run the block, print what it printed (for ``pytest -s``), and check it against the doc."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block.code, str(DOC), "exec"), namespace)
    print(out.getvalue(), end="")
    assert same_print(out.getvalue(), block.shown), (
        f"section {block.section} ({block.heading}) printed\n{out.getvalue()}\nbut the doc shows\n{block.shown}")


def run_imports(block: Block, namespace: dict) -> None:
    tree = ast.parse(block.code)
    tree.body = [node for node in tree.body if isinstance(node, (ast.Import, ast.ImportFrom))]
    exec(compile(ast.unparse(tree), str(DOC), "exec"), namespace)


@pytest.fixture
def clean_registry():
    before = dict(EFFECTS)
    yield
    EFFECTS.clear()
    EFFECTS.update(before)


def test_same_print_allows_a_rounding_only() -> None:
    assert same_print("c = 14.9 N s/m [14.1, 15.6]\n", "c = 14.8 N s/m [14.1, 15.6]")
    assert same_print("offset 1e-05 m, 88%", "offset 2e-05 m, 87%")
    assert not same_print("c = 14.9 N s/m", "c = 14.7 N s/m")
    assert not same_print("c = 14.9 N s/m", "c = 14.9 N/m")
    assert not same_print("a\nb", "a b") and not same_print("", "1")


def test_tutorial_code_runs_and_finds_the_new_effect(clean_registry) -> None:
    namespace: dict = {"__name__": "tutorial"}
    for block in blocks():
        if block.section >= RIPPLE_SECTION:
            continue
        if block.heading == LIBRARY_ALONE:
            run_imports(block, namespace)        # the loop test runs it
        else:
            run(block, namespace)
    assert "viscous_drag" in EFFECTS and "alone" not in namespace
    report = namespace["report"]
    assert report["missing_effect"] == "viscous_drag"
    assert report["candidates"][0]["params"]["c_N_s_m"] == pytest.approx(TRUE_DRAG_N_S_M, rel=0.2)
    assert namespace["fit"].error_mm_ < 0.3 * namespace["fit"].baseline_error_mm_
    assert namespace["quick"].candidates_[0].effect in ("viscous_drag", "rate_friction")


@pytest.mark.long      # the library-alone diagnosis tries entries in combination: about 25 CPU s
def test_tutorial_loop_located_written_fitted(clean_registry) -> None:
    """Sections 5-6: the library alone leaves more than the scatter; located: a force following slip speed, with
    the drag's own form (against the motion, at the mass centre) named or among its look-alikes; the drag fitted:
    the error falls to within the scatter as the workbench counts it, and its interval holds the truth."""
    namespace: dict = {"__name__": "tutorial"}
    for block in blocks():
        if block.section <= SETUP_SECTIONS or block.heading == LIBRARY_ALONE or block.section == LOOP_SECTIONS[1]:
            run(block, namespace)
        elif block.section < RIPPLE_SECTION:
            run_imports(block, namespace)
    assert "report" not in namespace                     # the diagnosis with the drag did not run here
    first, found, fit = namespace["first"], namespace["found"], namespace["fit"]
    scatter = first["repeat_scatter_mm"]
    assert first["candidates"][0]["cv_error_mm"] > EXPLAINED_FACTOR * scatter
    assert first["verdict"] != "library_effect" and first["located"] is None
    assert found.term is not None and found.term.follows == "slip speed", found.sentence
    drag_form = "mass centre along -e1 following slip speed"
    assert drag_form in (found.term.label, *found.lookalikes), found.sentence
    assert found.error_after_mm < 0.5 * found.error_mm
    lo, hi = fit.ci95_["viscous_drag"]["c_N_s_m"]
    assert lo <= TRUE_DRAG_N_S_M <= hi
    assert fit.error_mm_ <= EXPLAINED_FACTOR * scatter < fit.baseline_error_mm_


def test_tutorial_ripple_with_a_per_test_phase(clean_registry) -> None:
    """Section 9: the oscillating thrust with a random phase per test (amplitude and frequency shared), started
    apart from its neutral amplitude and at the residual's dominant frequency: the error falls, the amplitude is
    near the truth with an interval that holds it, every test's phase is found."""
    namespace: dict = {"__name__": "tutorial"}
    for block in blocks():
        if block.section <= SETUP_SECTIONS or block.section >= RIPPLE_SECTION:
            run(block, namespace)
        else:
            run_imports(block, namespace)
            assert not {"report", "fit", "alone", "found"} & set(namespace)      # sections 5-8 did not run here
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
