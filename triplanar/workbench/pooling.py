"""Normal scores pooled over independent units (load levels, tests) into one p-value: a shift of one sign in every
unit, or one that changes between units."""

from __future__ import annotations

import math

import numpy as np


def pooled_p(z: np.ndarray) -> float:
    """Two-sided p-value of standard normal scores ``z``, one per unit (load level, test), pooled: Stouffer's sum (a
    shift of one sign in every unit) or the sum of squares (chi-square with ``len(z)`` degrees of freedom: a shift
    that changes between units), the smaller doubled; 1 for no score.
    :func:`~triplanar.workbench.evidence.systematic_bias` pools its load levels with it,
    :mod:`~triplanar.workbench.rigidity` its tests."""
    from scipy.stats import chi2, norm
    if not len(z):
        return 1.0
    stouffer = 2 * float(norm.sf(abs(float(np.sum(z))) / math.sqrt(len(z))))
    return min(1.0, 2 * min(stouffer, float(chi2.sf(float(np.sum(z ** 2)), len(z)))))
