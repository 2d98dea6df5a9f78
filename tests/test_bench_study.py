"""The bench study (experiments.bench_study): recommendation logic, and a tiny end-to-end run that resumes."""

from __future__ import annotations

import csv
import math

import pytest

from experiments import bench_study as bs


def _row(design, demand, controller, success, error):
    score = (error * success + 10.0 * (1 - success)) if not math.isnan(error) else 10.0
    return [design, 0.5, 20.0, 0.0, 2e-4, controller, success, error, score, demand]


def test_best_rows_keep_the_best_scripted_and_ppo():
    rows = [_row("a", 3, "fixed_tip", 1.0, 5.0), _row("a", 3, "pi_feedback", 1.0, 2.0), _row("a", 3, "ppo_robust",
                                                                                              1.0, 3.0)]
    out = bs._best_rows(rows)
    assert [r[5] for r in out] == ["best_scripted:pi_feedback", "ppo_robust"]


def test_recommendation_is_the_least_demanding_design_meeting_the_target():
    rows = [_row("cheap", 2, "best_scripted:fixed_tip", 0.90, 0.5),     # too many failures
            _row("mid", 4, "best_scripted:pi_feedback", 0.96, 0.8),     # meets it
            _row("dear", 7, "ppo_robust", 1.0, 0.3)]                    # meets it, more demanding
    assert "mid" in bs.recommend(rows)
    assert bs.recommend(rows[:1]).startswith("No design")


def test_design_demand_orders_hardware():
    cheap = bs.Design("x", 8.0, 5.0, 0.01, 1e-3)
    dear = bs.Design("y", 0.5, math.inf, 0.0, 5e-5)
    assert cheap.demand() == 0 and dear.demand() == 8


@pytest.mark.slow
def test_tiny_study_runs_and_resumes(tmp_path, monkeypatch):
    monkeypatch.setattr(bs, "N_HELDOUT", 2)
    monkeypatch.setattr(bs, "TUNING_BENCHES", 2)
    monkeypatch.setattr(bs, "PI_GRID", [(1.0, 0.0)])
    monkeypatch.setattr(bs, "ADAPTIVE_GRID", (1e4,))
    kwargs = dict(seeds=[0], ppo_timesteps=512, recurrent_timesteps=512, design_ppo_timesteps=512,
                  designs=bs.DESIGNS[:1], executor="serial", log=lambda s: None)
    bs.run_bench_study(tmp_path, **kwargs)
    with open(tmp_path / "heldout.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["bench_set"] for r in rows} == {"nominal", "heldout"}
    assert {"steel_tip", "frictionless_tip", "pi_feedback", "adaptive", "ppo_robust",
            "ppo_recurrent"} <= {r["controller"] for r in rows}
    recurrent = [r for r in rows if r["controller"] == "ppo_recurrent"]
    assert {r["bench_set"] for r in recurrent} == {"nominal", "heldout"}
    assert all(int(r["n_episodes"]) > 0 for r in recurrent)
    with open(tmp_path / "designs.csv") as f:
        header = next(csv.reader(f))
    assert header[:8] == ["design", "tip_friction_deg", "stage_bandwidth_hz", "latency_s", "sensor_noise_m",
                          "controller", "success_rate", "mimicry_error_mm"]
    for name in ("heldout.png", "designs.png", "robust_learning_curves.png", "recommendation.txt"):
        assert (tmp_path / name).stat().st_size > 0
    stamps = {kind: (tmp_path / kind / "seed_0" / "final_model.zip").stat().st_mtime_ns
              for kind in ("ppo_robust", "ppo_recurrent")}
    bs.run_bench_study(tmp_path, **kwargs)   # resumes: nothing is trained again
    assert stamps == {kind: (tmp_path / kind / "seed_0" / "final_model.zip").stat().st_mtime_ns
                      for kind in ("ppo_robust", "ppo_recurrent")}
