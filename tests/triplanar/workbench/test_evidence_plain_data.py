"""A diagnosis's Evidence written as plain data (``triplanar.plain_data``: JSON and arrays, no pickle) and read back
gives the same Verdict: the rules compare entries by what they are (``CandidateResult.key``), never by identity (a
read-back Evidence's ``best`` is a copy of its entry in ``ranked``). Evidence made by hand: no simulation."""

from __future__ import annotations

import math
from pathlib import Path

from triplanar import plain_data
from triplanar.workbench.parameters import FitParameter
from triplanar.workbench.rules import decide
from triplanar.workbench.spec import ModelSpec
from triplanar.workbench.sweep import CandidateResult
from triplanar.workbench.verdict import Evidence

QUIET = {"systematic": False, "p_value_all": 1.0, "feature": None}


def _entry(effect: str, param: str, value: float, cv: float, errors: list[float]) -> CandidateResult:
    p = FitParameter(effect, param, value, True, 0.0, 30.0, stderr=0.2, ci95=(value - 0.4, value + 0.4),
                     status="fitted")
    return CandidateResult(effect, {param: p}, cv, cv, 1 - cv / 10.0, True, [],
                           held_out_mm={f"t{i}": e for i, e in enumerate(errors)})


def test_evidence_read_back_from_plain_data_gives_the_same_verdict(tmp_path: Path) -> None:
    best = _entry("end_friction", "phi_deg", 8.1, 0.55, [0.5, 0.6, 0.55, 0.55])
    runner = _entry("contact_friction", "phi1_deg", 20.0, 1.42, [1.4, 1.5, 1.4, 1.4])
    ev = Evidence(ModelSpec(), ModelSpec(), {}, [[30.0], [40.0]], [], 10.0, {30.0: 10.0}, 0.5, 0.2, 0.1, 0.7, 0.2,
                  [best, runner], {}, QUIET, best, [], None, {}, math.nan, QUIET)
    plain_data.save(tmp_path / "evidence.npz", ev)
    back = plain_data.load(tmp_path / "evidence.npz")
    assert back.best is not back.ranked[0] and back.best.key == back.ranked[0].key     # copies, not one object
    verdict, again = decide(ev), decide(back)
    assert verdict.confidence == "high", verdict.reason      # the runner-up is another entry, not the best itself
    assert again == verdict
