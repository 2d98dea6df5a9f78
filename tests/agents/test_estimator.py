"""The hypothesis bank of ``mpc``: what it varies (v1's unknowns, tilts and mass included), that every hypothesis
starts as the bench's block did, and that resample-move refines it."""

from __future__ import annotations

import numpy as np
import pytest

from agents.estimator import N_REPORTED, SpecimenBank, bench_of, hypothesis_of
from envs.core import make_config
from envs.triplanar_shear_v1 import draw_bench


def _bank(size: int = 8, **kwargs) -> SpecimenBank:
    specimen, foundation = make_config(None).base_specimen()
    env_kwargs = {"specimen": specimen, "foundation": foundation, "observation_mode": "state", "sensor_noise_m": 0.0}
    return SpecimenBank(specimen, foundation, env_kwargs, size, **kwargs)


def test_a_hypothesis_vector_rebuilds_the_bench_it_came_from():
    specimen, foundation = make_config(None).base_specimen()
    bench = draw_bench(np.random.default_rng(5), specimen, foundation)
    rebuilt = bench_of(specimen, hypothesis_of(bench), bench.load_N)
    assert rebuilt.load_N == bench.load_N
    for name in ("contact_points_m", "friction_deg", "tip_friction_deg", "mass_kg", "inertia_kg_m2", "mass_centre_m"):
        assert np.allclose(getattr(rebuilt.specimen, name), getattr(bench.specimen, name), rtol=1e-12, atol=1e-15), name
    for a, b in zip(rebuilt.foundation.planes, bench.foundation.planes):
        assert (a.dip_deg, a.dip_direction_deg) == pytest.approx((b.dip_deg, b.dip_direction_deg))


def test_the_bank_varies_mass_and_tilts_and_is_full_of_hypotheses_that_start():
    """At a low load friction holds many of the prior's specimens at rest; the bench's block started, so the bank
    draws until it holds ``size`` hypotheses that start (each with its own mass and plane tilts)."""
    bank = _bank(16)
    bank.reset(28.0)
    assert len(bank.states) == 16
    geometry = bank.theta[:, 7:N_REPORTED]
    assert np.all(np.ptp(geometry, axis=0) > 0.0)  # mass and each plane's dip differ between hypotheses
    fixed = _bank(16, vary_geometry=False)
    fixed.reset(28.0)
    assert np.all(np.ptp(fixed.theta[:, 7:N_REPORTED], axis=0) == 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("replan_every", [
    2,
    # long (`make test-slow`): a whole mpc episode whose only use is to show a documented miss still misses
    # Not strict: the miss depends on the machine. On 2026-11-28's machine it passed (XPASS) on the code of four
    # branches that share commit a411acb and differ elsewhere (workbench, mpc's optional bound, env registration,
    # input checks), so the commands of a whole episode differ with the CPU's floating-point kernels, as the
    # recurrent card's 1e-8 did (tests/experiments/test_evaluate.py).
    pytest.param(1, marks=[pytest.mark.long, pytest.mark.xfail(strict=False, reason=(
        "with mpc replanning every period the commands differ and, on some machines, on this tilted bench the 95 % "
        "interval ends at 6.22-7.43 deg, missing the 6 deg tip by 0.2 deg: one bench's interval misses under some "
        "command sequence, as a 95 % interval may; that the bank is a sample of the posterior is "
        "tests/agents/test_estimator_posterior.py's (its mean and spread against a brute-force grid)"))]),
])
def test_estimator_finds_a_known_tip_friction_on_tilted_planes(replan_every):
    """The nominal specimen with a 6 deg tip on planes tilted within v1's ranges, noiseless data, ``mpc`` in the
    loop (commands that excite the tip from the first period): the tip-friction interval should hold 6 deg and be
    narrower than half the prior's, after the bank has moved (the tilts are among what it varies and refines).
    With the earlier greedy move (``move="greedy"``) it missed: 6.25-7.81 deg; the Metropolis-Hastings move keeps
    the bank a posterior sample (``tests/agents/test_estimator_posterior.py``). Under the commands of ``mpc``
    replanning every second period (the seventh round's), with the tutorial's planner budget (16 samples, 2
    iterations, as ``tests/agents/test_mpc.py``'s noiseless test: the estimator is what is tested; mpc's 64 and 4
    cost 26 s of CPU, this 15 s), and every period (the eighth's, mpc's budget)."""
    from dataclasses import replace

    from agents.heldout import run_episode
    from agents.mpc import MPCController
    from envs.triplanar_shear_v1 import unknown_bench
    from triplanar.specimen import Plane
    specimen, foundation = make_config(None).base_specimen()
    tilts = ((0.3, 200.0), (0.4, 3.0), (-0.3, -4.0))
    planes = tuple(Plane(abs(p.dip_deg + d), p.dip_direction_deg + a) for p, (d, a) in zip(foundation.planes, tilts))
    bench = unknown_bench(replace(specimen, tip_friction_deg=6.0), tuple(specimen.friction_deg), 6.0, 1.0,
                          np.asarray(specimen.mass_centre_m), planes, 40.0, "tilted")
    # the long case keeps mpc's budget, under which its documented miss was seen
    budget = {"samples": 16, "iterations": 2} if replan_every == 2 else {}
    controller = MPCController(sensor_noise_m=0.0, start_periods=0, replan_every=replan_every, **budget)
    outcome = run_episode(controller, bench, env_kwargs={"sensor_noise_m": 0.0})
    low, high = controller.info["tip_friction_interval_deg"]
    assert outcome.success, outcome.reason
    assert controller.bank.rejuvenations > 0
    assert low <= 6.0 <= high, (low, high, controller.info["estimate"])
    assert high - low < 0.5 * 9.0, (low, high)


def _measured_bank(periods: int, **kwargs) -> tuple[SpecimenBank, np.ndarray]:
    """A bank fed ``periods`` noiseless periods of a drawn bench under a thrust and offset excitation, and that
    bench's hypothesis vector."""
    from agents.heldout import random_benches
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    bench = random_benches(1, 7)[0]
    bank = _bank(16, **kwargs)
    bank.reset(bench.load_N)
    env = TriPlanarShearV1Env(sensor_noise_m=0.0)
    env.reset(seed=0, options={"bench": bench})
    nominal = np.array([2.0 / env.unwrapped.config.thrust_scale - 1.0, 0.0])
    for k in range(periods):
        action = nominal + (0.05 if (k // 4) % 2 == 0 else -0.05) * np.array([1.0, -4.0])
        obs = env.step(action.astype(np.float32))[0]
        bank.update(action, obs)
    return bank, hypothesis_of(bench)


def test_residuals_are_the_likelihood_and_refinement_weighs_each_hypothesis_by_its_replay():
    """Half the sum of squares of a hypothesis's residuals is its replayed log-likelihood; after the Laplace
    refinement (:mod:`agents.refine`) every hypothesis's log-likelihood is its own replay's, its weights are finite and
    normalised, and the fit it drew around explains the data better than the bank's likeliest hypothesis did."""
    bank, truth = _measured_bank(12)
    for theta in (truth, bank.theta[0]):
        r = bank._residuals(theta)
        state, _ = bank._start(bank._bench_of(theta))
        assert -0.5 * float(r @ r) == pytest.approx(bank._replay(state), rel=1e-12)
    best = float(np.max(bank.ll[bank.alive]))
    assert bank.refine()
    assert bank.refined == bank.refinements == 1
    assert -bank.last_fit_cost > best
    w = bank.weights()
    assert np.all(np.isfinite(w)) and w.sum() == pytest.approx(1.0)
    for theta, ll in zip(bank.theta[:4], bank.ll[:4]):
        state, _ = bank._start(bank._bench_of(theta))
        assert bank._replay(state) == pytest.approx(ll, rel=1e-12)


def test_refinement_runs_every_refine_every_periods():
    bank, _ = _measured_bank(10, refine_every=5, refine_evaluations=5)
    assert bank.refinements == 2


def test_reference_distance_is_the_mean_horizontal_distance_of_the_contact_points():
    from agents.estimator import reference_distance_mm
    rng = np.random.default_rng(3)
    table = rng.normal(size=(11, 9)) * 1e-3
    shifted = table.copy()
    shifted[:, 0::3] += 3e-4  # along e1
    shifted[:, 2::3] += 4e-4  # along e3: 0.5 mm horizontally
    shifted[:, 1::3] += 1e-2  # vertical: not counted
    assert reference_distance_mm(table, table) == 0.0
    assert reference_distance_mm(table, shifted) == pytest.approx(0.5, rel=1e-9)


def test_the_banks_reference_is_its_hypotheses_references_weighed():
    bank, _ = _measured_bank(6)
    w = bank.weights()
    assert np.allclose(bank.reference(), sum(wi * s.ref for wi, s in zip(w, bank.states)), rtol=0, atol=1e-15)
