"""The README's RL quick start script runs, both ways, at a tiny budget and writes what the docs say it writes."""

from __future__ import annotations

import csv
import json
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "train_ppo_v1.py"
DOCUMENTED = ("model.zip", "vecnormalize.pkl", "heldout_episodes.csv", "summary.json")   # docs/environment.md


@pytest.mark.slow
@pytest.mark.parametrize("route", ["adapter", "plain"])
def test_quickstart_script_trains_and_scores(route: str, tmp_path: Path, monkeypatch, capsys) -> None:
    """The script run as ``python examples/train_ppo_v1.py ...`` runs it (``runpy``, as ``__main__``), in the test's
    process: an interpreter of its own would spend about 6 CPU s importing torch and SB3 again."""
    import torch
    assert "examples/train_ppo_v1.py" in (ROOT / "README.md").read_text()
    out = tmp_path / "run"
    monkeypatch.setattr(sys, "argv", [str(SCRIPT), "--timesteps", "1", "--eval-benches", "2", "--route", route,
                                      "--out", str(out)])
    threads = torch.get_num_threads()
    # one torch thread: the script sets none, and torch's default (a thread per core) spins on the cores the other
    # test worker uses (24 s of CPU instead of 12 for the adapter route)
    torch.set_num_threads(1)
    try:
        runpy.run_path(str(SCRIPT), run_name="__main__")
    finally:
        torch.set_num_threads(threads)
    assert "held-out benches" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(DOCUMENTED)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["route"] == route and summary["n_episodes"] == 2 and summary["target_mm"] == 1.0
    assert summary["return_low"] <= summary["mean_return"] <= summary["return_high"]
    assert 0.0 <= summary["success_low"] <= summary["success_rate"] <= summary["success_high"] <= 1.0
    with open(out / "heldout_episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["bench"]) for r in rows] == [0, 1]
    assert abs(sum(float(r["return"]) for r in rows) / 2 - summary["mean_return"]) < 1e-9
