"""``experiments.deviation_noise``: the probe perturbs only the five estimated deviation values, by a bias constant
within an episode (plus per-decision noise when asked), and leaves CP1's x deviation and the slope exact."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents.heldout import nominal_benches, run_episode
from agents.robust_policy import DeviationPolicy
from experiments.deviation_noise import NoisyDeviationPolicy

PLAIN = 4 * 15



def _inputs(recording_model, bias_mm: float, noise_mm: float) -> np.ndarray:
    recorder = recording_model()
    policy = DeviationPolicy(recorder, recorder)
    if bias_mm or noise_mm:
        policy = NoisyDeviationPolicy(policy, bias_mm, noise_mm, seed=4)
    run_episode(policy, nominal_benches((40.0,))[0], seed=0)
    return np.array(recorder.inputs)


def test_the_bias_is_constant_within_an_episode_and_only_on_the_estimated_values(recording_model):
    exact, biased, noisy = (_inputs(recording_model, b, n) for b, n in ((0.0, 0.0), (0.2, 0.0), (0.0, 0.2)))
    assert len(exact) == len(biased) == len(noisy) > 2   # zero actions: the same episode each time
    diff = (biased - exact)[:, PLAIN:]
    np.testing.assert_array_equal(diff[:, [0] + list(range(6, 12))], 0.0)
    assert np.all(np.abs(diff[:, 1:6]) > 1e-4)
    np.testing.assert_allclose(diff[:, 1:6], np.tile(diff[0, 1:6], (len(diff), 1)), atol=1e-5)
    wobble = (noisy - exact)[:, PLAIN + 1:PLAIN + 6]
    assert np.std(wobble[:, 0]) > 0.05   # per-decision noise changes from one decision to the next
