"""The README's RL quick start script runs, both ways, at a tiny budget and writes what the docs say it writes."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "train_ppo_v1.py"
DOCUMENTED = ("model.zip", "vecnormalize.pkl", "heldout_episodes.csv", "summary.json")   # docs/environment.md


@pytest.mark.slow
@pytest.mark.parametrize("route", ["adapter", "plain"])
def test_quickstart_script_trains_and_scores(route: str, tmp_path: Path) -> None:
    assert "examples/train_ppo_v1.py" in (ROOT / "README.md").read_text()
    # one torch thread: the script sets none, and torch's default (a thread per core) spins on the cores the other
    # test worker uses (24 s of CPU instead of 12 for the adapter route)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "OMP_NUM_THREADS": "1"}
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, str(SCRIPT), "--timesteps", "1", "--eval-benches", "2", "--route", route,
                           "--out", str(out)], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(DOCUMENTED)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["route"] == route and summary["n_episodes"] == 2 and summary["target_mm"] == 1.0
    assert summary["return_low"] <= summary["mean_return"] <= summary["return_high"]
    assert 0.0 <= summary["success_low"] <= summary["success_rate"] <= summary["success_high"] <= 1.0
    with open(out / "heldout_episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["bench"]) for r in rows] == [0, 1]
    assert abs(sum(float(r["return"]) for r in rows) / 2 - summary["mean_return"]) < 1e-9
