"""The bench study (experiments.bench_study): recommendation logic, and a tiny end-to-end run that resumes."""

from __future__ import annotations

import csv
import functools
import math

import pytest

from agents import bench_controllers
from agents.limit import LimitController
from agents.mpc import MPCController
from experiments import bench_study as bs
from experiments.episodes import run_batch
from experiments.evaluate import scripted_batch
from triplanar.executor import TaskCheckpoint


def _row(design, demand, controller, success, error, low, high):
    return {"design": design, "tip_friction_deg": 0.5, "stage_bandwidth_hz": 20.0, "latency_s": 0.0,
            "sensor_noise_m": 2e-4, "demand": demand, "controller": controller, "success_rate": success,
            "success_low": success - 0.05, "success_high": min(1.0, success + 0.05), "mimicry_error_mm": error,
            "error_low_mm": low, "error_high_mm": high, "score": error}


def test_best_rows_keep_the_best_scripted_and_ppo():
    rows = [_row("a", 3, "steel_tip", 1.0, 5.0, 4, 6), _row("a", 3, "pi_feedback", 1.0, 2.0, 1.5, 2.5),
            _row("a", 3, "ppo_robust", 1.0, 3.0, 2.5, 3.5)]
    assert [r["controller"] for r in bs.best_rows(rows)] == ["best_scripted:pi_feedback", "ppo_robust"]


def test_recommendation_names_a_design_only_when_its_interval_is_under_the_target():
    rows = [_row("cheap", 2, "best_scripted:steel_tip", 0.90, 0.5, 0.4, 0.6),    # too many failures
            _row("mid", 4, "best_scripted:pi_feedback", 0.96, 0.8, 0.7, 0.95),   # interval under 1 mm
            _row("dear", 7, "ppo_robust", 1.0, 0.3, 0.2, 0.4)]                   # under it, more demanding
    text = bs.recommend(rows)
    assert "Least demanding" in text and ": mid (" in text and "dear (ppo_robust)" in text
    # a mean under 1 mm whose interval reaches above it is not named; the overlapping designs are listed
    rows = [_row("a", 2, "ppo_robust", 1.0, 0.9, 0.7, 1.1), _row("b", 3, "ppo_robust", 1.0, 1.0, 0.8, 1.2),
            _row("c", 4, "ppo_robust", 1.0, 1.5, 1.3, 1.7)]
    text = bs.recommend(rows)
    assert text.startswith("No design") and "Best by the upper end: a with" in text
    assert "b (ppo_robust)" in text and "c (ppo_robust)" not in text


def test_design_demand_orders_hardware():
    cheap = bs.Design("x", 8.0, 5.0, 0.01, 1e-3)
    dear = bs.Design("y", 0.5, math.inf, 0.0, 5e-5)
    assert cheap.demand() == 0 and dear.demand() == 8


@pytest.mark.slow
@pytest.mark.long  # study-scale: four PPO trainings, eight controllers on three bench sets, the study run three times
def test_tiny_study_runs_and_resumes(tmp_path, monkeypatch):
    monkeypatch.setattr(bs, "TUNING_BENCHES", 2)
    monkeypatch.setattr(bs, "PI_GRID", [(1.0, 0.0)])
    monkeypatch.setattr(bs, "ADAPTIVE_GRID", (1e4,))
    # The study's plumbing, not the model-based controllers' quality: small searches and no least-squares refinement
    # (the defaults cost about 5 times this CPU for limit, 3 times for mpc).
    monkeypatch.setattr(bench_controllers, "LimitController",
                        functools.partial(LimitController, horizon=16, samples=24, iterations=2))
    monkeypatch.setattr(bench_controllers, "MPCController",
                        functools.partial(MPCController, horizon=16, samples=24, iterations=2, refine_every=0))
    kwargs = dict(seeds=[0], ppo_timesteps=512, recurrent_timesteps=512, design_seeds=[0, 1],
                  design_ppo_timesteps=512, n_heldout=2, scripted_seeds=[0, 1], designs=bs.DESIGNS[:1],
                  executor="serial", log=lambda s: None, doc=tmp_path / "doc" / "report.md")
    bs.run_bench_study(tmp_path, **kwargs)
    with open(tmp_path / "heldout.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["bench_set"] for r in rows} == {"nominal", "heldout", "stress"}
    assert all(float(r["error_low_mm"]) <= float(r["error_high_mm"]) for r in rows if r["mimicry_error_mm"] != "nan")
    assert {"steel_tip", "frictionless_tip", "pi_feedback", "adaptive", "ppo_robust",
            "ppo_recurrent", "mpc", "limit", *bs.SHIPPED_ROWS} <= {r["controller"] for r in rows}
    banked = [r for r in rows if r["controller"] == "ppo_banked" and r["bench_set"] == "heldout"]
    assert len(banked) == 1 and banked[0]["n_seeds"] == "3"   # the shipped agent's card's seeds
    recurrent = [r for r in rows if r["controller"] == "ppo_recurrent"]
    assert {r["bench_set"] for r in recurrent} == {"nominal", "heldout", "stress"}
    assert all(int(r["n_episodes"]) > 0 for r in recurrent)
    with open(tmp_path / "designs.csv") as f:
        header = next(csv.reader(f))
    assert header[:10] == ["design", "tip_friction_deg", "stage_bandwidth_hz", "latency_s", "sensor_noise_m",
                           "demand", "controller", "n_benches", "n_seeds", "n_episodes"]
    with open(tmp_path / "designs.csv") as f:
        ppo = [r for r in csv.DictReader(f) if r["controller"] == "ppo_robust"]
    assert len(ppo) == 1 and ppo[0]["n_seeds"] == "2"
    with open(tmp_path / "designs.csv") as f:
        design_controllers = {r["controller"] for r in csv.DictReader(f)}
    assert {"limit", "information_bound"} <= design_controllers and "mpc" not in design_controllers  # the default
    assert "x the limit" in (tmp_path / "recommendation.txt").read_text()
    report = (tmp_path / "bench_report.md").read_text()
    assert "95 % CI" in report and "wall time" in report and "2 seeds x 512 steps per design" in report
    assert "](../heldout.png)" in (tmp_path / "doc" / "report.md").read_text()
    for name in ("heldout.png", "designs.png", "robust_learning_curves.png", "recommendation.txt",
                 "bench_summary.json"):
        assert (tmp_path / name).stat().st_size > 0
    stamps = {kind: (tmp_path / kind / "seed_0" / "final_model.zip").stat().st_mtime_ns
              for kind in ("ppo_robust", "ppo_recurrent")}
    bs.run_bench_study(tmp_path, **kwargs)   # resumes: nothing is trained again
    assert stamps == {kind: (tmp_path / kind / "seed_0" / "final_model.zip").stat().st_mtime_ns
                      for kind in ("ppo_robust", "ppo_recurrent")}
    table = (tmp_path / "heldout.csv").read_text()
    stored = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "tasks").glob("*.npz")}
    bs.run_bench_study(tmp_path, **kwargs, rerun=["steel_tip", "mpc"])   # their code changed: run them again
    redone = [p.name for p in (tmp_path / "tasks").glob("*.npz") if p.stat().st_mtime_ns != stored.get(p.name)]
    # steel_tip: 3 bench sets x 2 noise seeds + the design's 2; mpc, in parts of PART_BENCHES benches: the nominal
    # bench's 12 loads in 2, held-out and stress 1 each (the design sweep leaves mpc out: DESIGN_MODEL_BASED)
    assert bs.PART_BENCHES == 10 and len(redone) == 8 + 4
    assert (tmp_path / "heldout.csv").read_text() == table   # the same code gives the same rows


def test_report_and_plots_take_a_row_without_successes(tmp_path):
    import numpy as np

    from agents.heldout import Outcome
    from experiments import bench_plots, bench_report
    from experiments.stats import row_stats

    failed = np.full((2, 3), np.nan)
    stats = row_stats(failed, np.zeros((2, 3), bool), 10.0)
    assert stats["success_rate"] == 0.0 and stats["score"] == 10.0 and math.isnan(stats["cvar10_mm"])
    good = np.array([[0.5, 0.7, 0.9], [0.6, 0.8, 1.0]])
    ok = row_stats(good, np.ones((2, 3), bool), 10.0)
    outcomes = [[Outcome("x", "heldout", i, 30.0, False, "lift_off", math.nan, 0.01, -1.0, 5) for i in range(3)]] * 2
    rows = [{"controller": "never", "bench_set": "heldout", **stats}, {"controller": "fine", "bench_set": "stress", **ok}]
    bench_plots.rows_plot(tmp_path / "rows.png", [(r["controller"], r["bench_set"], r, outcomes) for r in rows], "t")
    design_rows = [{"design": "d", "demand": 1, "controller": "ppo_robust", **stats},
                   {"design": "d", "demand": 1, "controller": "best_scripted:adaptive", **ok}]
    bench_plots.designs_plot(tmp_path / "designs.png", design_rows)
    summary = {"timings_s": {"tuning_s": 1.0, "ppo_training_s": 2.0, "evaluation_s": 3.0, "design_sweep_s": 4.0},
               "recurrent_timesteps": None, "seeds": [0], "ppo_timesteps": 10, "trained_timesteps": {},
               "designs": ["d"], "design_seeds": [0], "design_ppo_timesteps": 5, "n_heldout": 3, "n_stress": 3,
               "scripted_seeds": [0], "pi_gains": {}, "adaptive_gain": {}, "recommendation": "none named"}
    text = bench_report.markdown(summary, rows, design_rows)
    assert "| `never` | heldout | 3 x 2 | 0.0 (" in text and "| - | - | 10.00 (10.00-10.00) | -, - |" in text
    assert "recurrent PPO: none" in text and (tmp_path / "rows.png").stat().st_size > 0


def test_the_references_are_reported_per_design_and_only_real_time_controllers_recommended():
    def row(design, controller, score, high, demand=1):
        return {"design": design, "controller": controller, "score": score, "error_high_mm": high,
                "mimicry_error_mm": score, "error_low_mm": score / 2, "success_rate": 1.0, "success_low": 0.98,
                "success_high": 1.0, "n_benches": 50, "demand": demand, "tip_friction_deg": 3.0,
                "stage_bandwidth_hz": 20.0, "latency_s": 0.005, "sensor_noise_m": 2e-4}
    rows = [row("a", "limit", 0.4, 0.5, 0), row("a", "mpc", 0.6, 0.7, 0),
            row("a", "best_scripted:adaptive", 1.2, 1.4, 0), row("b", "limit", 0.3, 0.4, 2), row("b", "information_bound", 0.45, 0.5, 2), row("b", "mpc", 0.5, 0.6, 2),
            row("b", "ppo_robust", 0.9, 0.95, 2)]
    text = bs.recommend(rows)
    # a's interval under 1 mm is mpc's, which does not run in real time: b is named, with the controller to run
    assert "b (tip" in text and "b with ppo_robust" in text and "a (tip" not in text.split("Per design")[0]
    assert "a (mpc)" not in text
    assert "a: limit 0.40 mm (score, 50 benches); best real-time controller best_scripted:adaptive 1.20 mm = 3.00 x " \
           "the limit (mpc, not real time: 0.60 mm)" in text
    assert "b: limit 0.30 mm (score, 50 benches); bound 0.45 mm (score, 50 benches); best real-time controller " \
           "ppo_robust 0.90 mm = 3.00 x the limit, 2.00 x the bound (mpc, not real time: 0.50 mm)" in text


def test_model_based_batches_run_in_checkpointed_parts_with_the_whole_batch_outcomes(tmp_path, monkeypatch):
    # A model-based batch is checkpointed part by part (an interrupted study loses at most a part); its parts
    # together are the whole batch, episode for episode (numbered, seeded and planned as in one task).
    monkeypatch.setattr(bench_controllers, "MPCController",
                        functools.partial(MPCController, horizon=16, samples=24, iterations=2, refine_every=0))
    batches = [scripted_batch("mpc", None, "heldout", 3, 0), scripted_batch("steel_tip", None, "heldout", 3, 0)]
    whole = [run_batch(b) for b in batches]
    in_parts = bs.run_batches(batches, tmp_path, "serial", "test", part_benches=2)
    assert [repr(r) for r in in_parts] == [repr(r) for r in whole]
    stored = sorted((tmp_path / "tasks").glob("*.npz"))
    assert len(stored) == 3   # mpc's benches 0-1 and 2, steel_tip whole
    stored[0].unlink()   # an interruption lost one task: it alone runs again
    kept = {p.name: p.stat().st_mtime_ns for p in stored[1:]}
    assert [repr(r) for r in bs.run_batches(batches, tmp_path, "serial", "test", part_benches=2)] == \
        [repr(r) for r in whole]
    assert all((tmp_path / "tasks" / name).stat().st_mtime_ns == t for name, t in kept.items())
    # a model-based batch an earlier study stored whole is read whole, not run again in parts
    earlier = TaskCheckpoint(tmp_path / "earlier" / "tasks")
    earlier.save(earlier.key(run_batch, batches[0]), whole[0])
    assert repr(bs.run_batches(batches[:1], tmp_path / "earlier", "serial", "test", part_benches=2)) == repr(whole[:1])
    assert len(list((tmp_path / "earlier" / "tasks").glob("*.npz"))) == 1


def test_the_study_command_runs_the_study_at_its_own_defaults():
    # `triplanar study --bench` declares its options without importing experiments; its defaults must be the
    # study's (the command once left information_bound, the tables' bound column, out of every run).
    from triplanar.cli import build_parser

    from experiments.evaluate import MODEL_BASED
    args = build_parser().parse_args(["study", "--bench", "--out", "x"])
    assert args.model_based == list(MODEL_BASED)
    assert args.design_model_based == list(bs.DESIGN_MODEL_BASED)
    assert args.shipped == list(bs.SHIPPED_ROWS)
    assert (args.design_seeds, args.design_timesteps, args.n_heldout, args.n_model_based) == \
        (list(bs.DESIGN_SEEDS), bs.DESIGN_PPO_TIMESTEPS, bs.N_HELDOUT, bs.N_MODEL_BASED)


def test_the_report_opens_with_the_real_time_controllers_beside_the_bound():
    from experiments import bench_report

    def row(controller, bench_set, score):
        return {"controller": controller, "bench_set": bench_set, "score": score, "score_low": score - 0.1,
                "score_high": score + 0.1, "mimicry_error_mm": score, "error_low_mm": score - 0.1,
                "error_high_mm": score + 0.1, "success_rate": 1.0, "success_low": 0.98, "success_high": 1.0,
                "n_benches": 200, "n_seeds": 1}
    rows = [row("mpc", "heldout", 0.5), row("information_bound", "heldout", 0.4), row("adaptive", "heldout", 1.4),
            row("ppo_banked", "heldout", 0.9), row("ppo_banked", "stress", 1.5)]
    lines = bench_report.answer(rows, "Build x; run y.")
    table = [line for line in lines if line.startswith("| `")]
    # real-time controllers first, each by score, then mpc and the bound; the ratio is the score over the bound's
    assert [line.split("`")[1] for line in table] == ["ppo_banked", "adaptive", "information_bound", "mpc"]
    assert table[0].endswith("| 100.0 (98.0-100.0) | 1.50 (1.40-1.60) | 2.25 |") and "| yes |" in table[0]
    assert "| no |" in table[3] and table[1].endswith("| - | - | 3.50 |") and lines[2] == "Build x; run y."
