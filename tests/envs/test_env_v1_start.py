"""v1's fast start: the first control period runs before the hydrostatic reference, which is
computed only for a start that survives it. These check that this changes nothing: the period's outcome does not
depend on the reference, a start that ends in it does not compute the reference, and a seeded env draws the same
specimens as the code before the change did (``benchmarks/fingerprint.py`` checks whole rollouts bitwise)."""

from __future__ import annotations

import numpy as np
import pytest

import envs.core as T
from envs.triplanar_shear_v1 import TriPlanarShearV1Env, draw_bench


def _draws(n: int):
    config = T.make_config(None)
    specimen, foundation = config.base_specimen()
    for i in range(n):
        bench = draw_bench(np.random.default_rng([4242, i]), specimen, foundation)
        draw = T.EpisodeDraw(bench.load_N, tuple(bench.specimen.friction_deg), float(bench.specimen.tip_friction_deg))
        yield config, draw, bench


def test_the_first_period_ends_the_same_with_or_without_the_reference(monkeypatch):
    real = T.control_step
    checked = []

    def control_step(y, p, modes, armed, st, ref, action, cfg, obs, inf, ws):
        other = [a.copy() for a in (y, p, modes, armed, st)]
        code = real(y, p, modes, armed, st, ref, action, cfg, obs, inf, ws)
        other_ref = np.random.default_rng(len(checked)).uniform(-0.01, 0.01, ref.shape)
        other_code = real(*other, other_ref, action, cfg, np.empty_like(obs), np.empty_like(inf), T.new_workspace())
        assert other_code == code
        for a, b in zip((y, p, modes, armed), other[:4]):
            assert np.array_equal(a, b)
        checked.append(code)
        return code

    monkeypatch.setattr(T, "control_step", control_step)
    for config, draw, bench in _draws(12):
        try:
            T._compute_start(None, config, draw, bench.specimen, bench.foundation)
        except T.StartError:
            pass
    assert len(set(checked)) > 1   # some starts ended in the first period, some did not


def test_a_start_that_ends_in_the_first_period_computes_no_reference(monkeypatch):
    runs = []
    real = T.simulate
    monkeypatch.setattr(T, "simulate", lambda *a, **k: runs.append(1) or real(*a, **k))
    failed = ok = 0
    for config, draw, bench in _draws(12):
        before = len(runs)
        try:
            start = T._compute_start(None, config, draw, bench.specimen, bench.foundation)
        except T.StartError:
            failed += 1
            assert len(runs) == before
        else:
            ok += 1
            assert len(runs) == before + 1 and start.reference.shape == (T.REFERENCE_POINTS, 9)
    assert failed and ok


def test_seeded_resets_draw_the_specimens_they_drew_before_the_fast_start():
    # (load_N, tip_friction_deg) of the first 6 episodes with seed 123, one step each (its sensor noise comes from
    # the same generator), recorded with the code before the change (commit 8330442): the draws that could not
    # start were skipped exactly as before.
    before = [(45.189845359446, 10.192126157581), (43.537276599883, 5.318062544186),
              (35.950439667985, 8.033247094203), (49.613922557718, 11.594091530667),
              (44.893698979115, 9.868365692457), (37.112681791823, 9.996365553022)]
    env = TriPlanarShearV1Env(observation_mode="bench", randomize=True)
    got = []
    for k in range(6):
        env.reset(seed=123 if k == 0 else None)
        got.append((env.episode_bench.load_N, env.episode_bench.specimen.tip_friction_deg))
        env.step(np.array([0.3, -0.2], np.float32))
    assert got == [pytest.approx(b, rel=1e-11) for b in before]
