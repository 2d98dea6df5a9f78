"""An effect whose equations the paper leaves a choice in (``Effect.form_tolerance_m``) gets intervals that admit the
parameter change moving the traces by that tolerance; an effect without one keeps the statistical interval."""

from __future__ import annotations

import math

import pytest

from triplanar.effects import REGISTRY
from triplanar.workbench.intervals import form_allowance, interval95


def test_allowance_is_the_tolerance_at_the_fitted_sensitivity() -> None:
    # tau moved 0.04 s from 0 removed sqrt(7.25^2 - 0.92^2) = 7.19 mm: 0.6 mm of form tolerance is 0.0033 s
    assert form_allowance(0.04, 0.0, 7.25, 0.92, 0.6) == pytest.approx(0.6 * 0.04 / math.sqrt(7.25**2 - 0.92**2))
    assert form_allowance(0.04, 0.0, 7.25, 0.92, 0.0) == 0.0        # no tolerance
    assert form_allowance(0.0, 0.0, 7.25, 0.92, 0.6) == 0.0         # not moved
    assert form_allowance(0.04, 0.0, 0.9, 0.92, 0.6) == 0.0         # removed nothing


def test_interval_widens_by_the_allowance() -> None:
    args = (0.04, 1e-4, 0.0, 9, 1, 0.92, 0.85, (0.0, 2.0), 0.0, (0.0, 0.3))
    plain, _ = interval95(*args)
    wide, _ = interval95(*args, 1.0, 0.003)
    assert wide[0] == pytest.approx(plain[0] - 0.003) and wide[1] == pytest.approx(plain[1] + 0.003)


def test_only_the_actuator_rise_declares_a_form_tolerance() -> None:
    declared = {name for name, cls in REGISTRY.items() if cls.form_tolerance_m > 0}
    assert declared == {"actuator_rise"}
