"""Resample-move keeps the hypothesis bank a sample of the posterior: with one unknown (the tip friction) the
posterior is computed by brute force on a fine grid, and the bank's mean and spread must match it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from agents.estimator import SpecimenBank
from envs.core import OBS_POS, StartError, make_config
from envs.triplanar_shear_v1 import Bench, TriPlanarShearV1Env

LOAD_N = 40.0
SENSOR_NOISE_M = 2e-4
MODEL_ERROR_M = 6e-4  # the controller's default
PERIODS = 20


def _grid_posterior(env_kwargs: dict, specimen, foundation, actions, measured) -> tuple[float, float]:
    """Mean and standard deviation of the tip friction's posterior under the bank's likelihood (Gaussian
    rangefinder residuals, variance noise^2 + model error^2) and v1's uniform prior among specimens that start,
    by running every grid value through the env itself with the commands sent."""
    grid = np.linspace(3.0, 12.0, 361)
    ll = np.full(len(grid), -np.inf)
    var = SENSOR_NOISE_M ** 2 + MODEL_ERROR_M ** 2
    env = TriPlanarShearV1Env(**env_kwargs)
    for j, tip in enumerate(grid):
        try:
            env.reset(seed=0, options={"bench": Bench(replace(specimen, tip_friction_deg=float(tip)), foundation,
                                                      LOAD_N)})
        except StartError:
            continue  # friction holds it at rest: not in the prior
        total = 0.0
        for action, m in zip(actions, measured):
            obs, _, terminated, truncated, _ = env.step(action)
            r = obs[OBS_POS:OBS_POS + 9].astype(float) - m
            total += -0.5 * float(r @ r) / var
            if terminated or truncated:
                total = -np.inf
                break
        ll[j] = total
    w = np.exp(ll - ll.max())
    w /= w.sum()
    mean = float(w @ grid)
    return mean, float(np.sqrt(w @ (grid - mean) ** 2))


@pytest.mark.slow
def test_resample_move_keeps_a_sample_of_the_tip_frictions_posterior():
    specimen, foundation = make_config(None).base_specimen()
    fixed = {f"friction{k}_deg": (v, v) for k, v in enumerate(specimen.friction_deg, start=1)}
    fixed.update({f"mass_centre{k}_m": (v, v) for k, v in enumerate(np.asarray(specimen.mass_centre_m), start=1)})
    env_kwargs = {"specimen": specimen, "foundation": foundation, "observation_mode": "state", "sensor_noise_m": 0.0}
    bank = SpecimenBank(specimen, foundation, env_kwargs, 64, seed=1, sensor_noise_m=SENSOR_NOISE_M,
                        model_error_m=MODEL_ERROR_M, intervals=fixed, vary_geometry=False, move_steps=3)
    bank.reset(LOAD_N)
    bench = TriPlanarShearV1Env(sensor_noise_m=SENSOR_NOISE_M)
    obs, _ = bench.reset(seed=3, options={"bench": Bench(replace(specimen, tip_friction_deg=6.0), foundation,
                                                         LOAD_N)})
    action = np.array([2.0 / bench.config.thrust_scale - 1.0, bench.config.tip_offset_m / bench.config.offset_range_m])
    actions, measured = [], []
    for _ in range(PERIODS):
        obs = bench.step(action.astype(np.float32))[0]
        bank.update(action, obs)
        actions.append(action.astype(np.float32))
        measured.append(bank._history[-1][1])
    mean, sd = _grid_posterior(env_kwargs, specimen, foundation, actions, measured)
    assert sd < 0.5 * 9.0 / np.sqrt(12.0), sd  # the data say much more than the prior (3-12 deg)
    assert bank.rejuvenations > 0
    w = bank.weights()
    tips = bank.theta[:, 0]
    bank_mean = float(w @ tips)
    bank_sd = float(np.sqrt(w @ (tips - bank_mean) ** 2))
    assert abs(bank_mean - mean) < 0.5 * sd, (bank_mean, mean, sd)
    assert 0.5 * sd < bank_sd < 1.5 * sd, (bank_sd, sd)
