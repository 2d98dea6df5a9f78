"""The values a reproduction of the paper's results section produces: the :class:`Reproduction` (inputs,
simulations, tables, claims) and each evaluated :class:`Claim`. They live apart from the code that computes them
(:mod:`.reproduce`, :mod:`.claims`) so that the claims can read a reproduction that holds the claims without the two
modules importing each other."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..measurement import MeasuredTest
from ..specimen import Foundation
from . import tables as T
from .cases import Run, Simulator


@dataclass(frozen=True)
class Claim:
    number: int
    claim: str
    figure: str
    verdict: str
    details: dict = field(default_factory=dict)


@dataclass
class Reproduction:
    """Everything computed: inputs, simulations, tables, claims."""

    data_path: Path
    loads: list[float]
    tests_by_load: dict[float, list[MeasuredTest]]
    rest: np.ndarray
    foundation: Foundation
    simulator: Simulator
    runs: list[Run]
    case_rows: dict[str, list[T.CaseRow]]
    data_rows: list[T.DataRow]
    scaled_rows: list[T.ScaledRow]
    claims: list[Claim]
    seconds: dict[str, float]
