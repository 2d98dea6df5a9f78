"""Parsimony: how uncertain a difference of held-out errors is, and the one-standard-error rule over entries.

Used by :class:`~triplanar.workbench.diagnose.Diagnoser` to name the simplest entry that fits as well as the best,
and to find the entries the data cannot tell from it (look-alikes).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

if TYPE_CHECKING:
    from .candidate_result import CandidateResult


def difference_se(a: CandidateResult, b: CandidateResult) -> tuple[float, float]:
    """``(mean, standard error)`` over the tests of ``b``'s held-out squared error minus ``a``'s (mm^2): how much
    worse ``b`` is than ``a`` on held-out loads, and how uncertain that is (tests are the independent units;
    ``cv_b^2 - cv_a^2`` is the mean)."""
    common = sorted(set(a.held_out_mm) & set(b.held_out_mm))
    d = np.array([b.held_out_mm[t] ** 2 - a.held_out_mm[t] ** 2 for t in common])
    d = d[np.isfinite(d)]
    if len(d) < 2:
        return math.nan, math.nan
    return float(d.mean()), float(d.std(ddof=1) / math.sqrt(len(d)))


def parsimonious(entries: Sequence[CandidateResult]) -> tuple[CandidateResult, list[CandidateResult]]:
    """The one-standard-error rule over ``entries`` (best cross-validated error first): of the entries whose held-out
    error is within one standard error of the difference from the best's, the one with the fewest free parameters
    (then the lowest error). Returns it and the others within that standard error (its look-alikes).

    Why this rule: cross-validation errors of nested or competing fits differ by noise of about that standard error,
    so a more flexible entry that wins by less has not shown that its extra parameters are needed (Hastie,
    Tibshirani & Friedman, The Elements of Statistical Learning, 2nd ed., section 7.10)."""
    top = entries[0]
    close = [top]
    for other in entries[1:]:
        mean, se = difference_se(top, other)
        if math.isfinite(mean) and mean <= se:
            close.append(other)
    chosen = min(close, key=lambda c: (len(c.params) + len(c.per_test), c.cv_error_mm))
    look = [c for c in close if c.key != chosen.key]
    if chosen.key != top.key:      # the look-alikes of the chosen one: within its own standard error
        look = lookalikes_of(chosen, entries)
    return chosen, look


def lookalikes_of(entry: CandidateResult, entries: Sequence[CandidateResult]) -> list[CandidateResult]:
    """The entries (other than ``entry``) whose held-out error differs from ``entry``'s by at most one standard
    error of the difference: those the data cannot tell from it."""
    return [c for c in entries if c.key != entry.key and _within(entry, c)]


def _within(a: CandidateResult, b: CandidateResult) -> bool:
    mean, se = difference_se(a, b)
    return math.isfinite(mean) and abs(mean) <= se
