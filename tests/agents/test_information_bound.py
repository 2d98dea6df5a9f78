"""The information-limited bound (agents/information_bound.py): what the bench's sensors leave unknown, and the
bound's rows beside ``limit`` for every design of the study."""

import math

import numpy as np
import pytest

from agents.controller_specs import ScriptedSpec
from agents.heldout import bench_set
from agents.information_bound import InformationBound, deviation_bound, unknown_ranges
from experiments import bench_study as bs
from experiments.designs import DESIGNS
from experiments.episodes import EpisodeBatch, run_batch
from experiments.evaluate import MODEL_BASED, runs_in_real_time


def _commands(periods: int = 40) -> np.ndarray:
    """mpc's start, then the nominal command (a controller that learns and does nothing with it)."""
    from agents.mpc import MPCController
    from envs.core import make_config
    config, start = make_config(None), MPCController()
    head = [start.start_command(p, config) for p in range(1, start.start_periods + 1)]
    return np.array(head + [[0.0, 0.0]] * (periods - len(head)))


def test_a_known_tip_is_not_an_unknown():
    _, _, free = unknown_ranges()
    _, _, known = unknown_ranges(8.0)
    assert 0 in free and 0 not in known and set(known) == set(free) - {0}


def test_noisier_rangefinders_leave_more_unknown():
    """The Fisher information scales as 1/noise^2: five times the noise (a 1 mm rangefinder against the default
    0.2 mm) must leave a larger deviation bound on the same bench and commands."""
    bench = bench_set("heldout", 1)[0]
    quiet = deviation_bound(bench, _commands())
    noisy = deviation_bound(bench, _commands(), {"sensor_noise_m": 1e-3})
    assert quiet is not None and noisy is not None
    assert 0 < quiet["deviation_bound_mm"] < noisy["deviation_bound_mm"]
    assert quiet["covered"] == noisy["covered"] == 1.0


def test_the_bound_row_is_limit_after_the_start_with_the_unknown_in_quadrature():
    """One held-out bench: the bound's episode plays mpc's start and then limit; its outcome is the episode's
    error and the deviation bound in quadrature, so never below the episode's own error."""
    batch = EpisodeBatch.of(ScriptedSpec("information_bound"), "information_bound", "heldout", 1)
    [outcome] = run_batch(batch)
    assert outcome.success and outcome.reason.startswith("information_bound (deviation ")
    deviation = float(outcome.reason.split("deviation ")[1].split(" mm")[0])
    assert 0.05 < deviation < outcome.mimicry_error_mm < 1.0
    controller = InformationBound()
    assert controller.start_periods == 8 and not runs_in_real_time("information_bound")
    assert math.isfinite(outcome.mimicry_error_mm)


@pytest.mark.parametrize("design", DESIGNS, ids=lambda d: d.name)
def test_every_design_has_a_bound_row_beside_limit(design):
    labels = [b.label for b in bs.design_batches({}, {}, 4, [design], [0], list(MODEL_BASED), 2)]
    assert f"{design.name}|information_bound" in labels and f"{design.name}|limit" in labels
    bound = next(b for b in bs.design_batches({}, {}, 4, [design], [0], list(MODEL_BASED), 2)
                 if b.label.endswith("|information_bound"))
    assert bound.n == 2 and bound.tip_friction_deg == design.tip_friction_deg   # a known tip is not an unknown
