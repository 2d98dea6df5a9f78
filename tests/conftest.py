"""Shared test set-up: the fuzz tests' two sizes (hypothesis profiles), and isolation: a test that registers an effect
(a plugin, a tutorial) does not leave it registered for the tests after it (diagnose would otherwise consider it a
candidate)."""

from __future__ import annotations

import pytest
from hypothesis import settings

from triplanar.effects import REGISTRY

# The fuzz tests (hypothesis) draw 100 inputs each under `make test` and 1,000 under `make test-slow`, which passes
# `--hypothesis-profile=thorough` (the profile named on the command line wins over the one loaded here).
settings.register_profile("quick", max_examples=100)
settings.register_profile("thorough", max_examples=1000)
settings.load_profile("quick")


@pytest.fixture(autouse=True)
def _effect_registry_restored():
    before = dict(REGISTRY)
    yield
    REGISTRY.clear()
    REGISTRY.update(before)
