"""Shared test isolation: a test that registers an effect (a plugin, a tutorial) does not leave it registered for the
tests after it (diagnose would otherwise consider it a candidate)."""

from __future__ import annotations

import pytest

from triplanar.effects import REGISTRY


@pytest.fixture(autouse=True)
def _effect_registry_restored():
    before = dict(REGISTRY)
    yield
    REGISTRY.clear()
    REGISTRY.update(before)
