"""Shared test set-up: the fuzz tests' two sizes (hypothesis profiles), and isolation: a test that registers an effect
(a plugin, a tutorial) does not leave it registered for the tests after it (diagnose would otherwise consider it a
candidate)."""

from __future__ import annotations


import numpy as np
import pytest
from hypothesis import settings

from triplanar.effects import REGISTRY

# The fuzz tests (hypothesis) draw 100 inputs each under `make test` and 1,000 under `make test-slow`, which passes
# `--hypothesis-profile=thorough` (the profile named on the command line wins over the one loaded here).
settings.register_profile("quick", max_examples=100)
settings.register_profile("thorough", max_examples=1000)
settings.load_profile("quick")


class RecordingModel:
    """A stand-in for a trained PPO model and its normaliser (a policy of ``agents.robust_policy`` calls
    ``normalize_obs``, then ``predict``): records every input it is given; acts by ``act(x)``, zeros by default."""

    def __init__(self, act=None):
        self.inputs: list[np.ndarray] = []
        self._act = act

    def normalize_obs(self, x):
        return x

    def predict(self, x, deterministic=True):
        self.inputs.append(np.array(x))
        return (np.zeros(2, dtype=np.float32) if self._act is None else self._act(x)), None


@pytest.fixture(scope="session")
def recording_model():
    """:class:`RecordingModel`, to build stand-ins with (``recording_model(act=None)``)."""
    return RecordingModel


@pytest.fixture(autouse=True)
def _effect_registry_restored():
    before = dict(REGISTRY)
    yield
    REGISTRY.clear()
    REGISTRY.update(before)


# The longest tests first. `make test` runs on two xdist workers, which take tests in collection order as they
# become free, so a test of minutes collected near the end (the workbench's come last) would run alone on one worker
# while the other idles. These are the costliest tests of `make test` (CPU seconds measured with
# benchmarks/cpu_per_test.py, or the quiet CI's wall: docs/performance.md), longest first; the rest keep their order,
# the `slow` ones first.
# A name here that no longer exists is ignored: the list only orders, it selects nothing.
LONGEST_FIRST = (
    "tests/agents/test_train_resume.py::test_train_killed_and_rerun_finishes_without_touching_its_checkpoints",
        "tests/agents/test_mpc_prior.py::test_tutorial_identify_then_control",
    "tests/triplanar/commands/test_command_safety.py::test_diagnose_killed_and_rerun_resumes_to_the_same_report",
    "tests/triplanar/workbench/test_workbench_refit_parsimony.py::",
    "tests/triplanar/workbench/test_workbench_tutorial.py::",
    "tests/triplanar/workbench/test_workbench_user_effect.py::test_forward_selection_finds_the_users_effect",
    "tests/triplanar/commands/test_train_cli.py::test_a_killed_v1_run_continues_from_its_checkpoint",
    "tests/triplanar/workbench/test_workbench_instruments.py::test_a_lateral_gain_error_below_the_scatter",
    "tests/agents/test_mpc.py::test_estimator_finds_a_known_tip_friction_on_noiseless_data",
    "tests/triplanar/workbench/test_workbench_combinations.py::test_two_hidden_library_effects_are_both_named",
    "tests/triplanar/workbench/test_workbench_lookalikes.py::",
    "tests/agents/test_estimator.py::test_estimator_finds_a_known_tip_friction_on_tilted_planes",
)


def pytest_collection_modifyitems(config, items):
    def rank(item) -> tuple[int, int]:
        listed = [i for i, prefix in enumerate(LONGEST_FIRST) if item.nodeid.startswith(prefix)]
        if listed:
            return 0, listed[0]
        return (1 if item.get_closest_marker("slow") else 2), 0

    items.sort(key=rank)  # stable: within a rank, collection order
