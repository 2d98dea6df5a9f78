"""benchmarks/rl_reference.py rewrites docs/rl_reference.csv whole: a run of some rows in a new ``--work`` folder
replaces those rows and keeps the table's others as they were."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import rl_reference


def test_a_new_row_replaces_its_own_and_keeps_the_others(tmp_path, monkeypatch):
    table = tmp_path / "rl_reference.csv"
    monkeypatch.setattr(rl_reference, "CSV", table)
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir(), second.mkdir()
    row = {k: 1.0 for k in rl_reference.FIELDS} | {"bench": "default", "command": "c"}
    for name in ("random", "mpc"):
        (first / f"{name}.json").write_text(json.dumps(row | {"row": name}))
    rl_reference.write_table(first)
    (second / "mpc.json").write_text(json.dumps(row | {"row": "mpc", "mean_return": 2.0}))
    (second / "ppo_2m.json").write_text(json.dumps(row | {"row": "ppo_2m"}))
    rl_reference.write_table(second)
    rows = {r["row"]: r for r in rl_reference.csv_rows(table)}
    assert list(rows) == ["random", "ppo_2m", "mpc"]        # the script's row order
    assert float(rows["mpc"]["mean_return"]) == 2.0 and float(rows["random"]["mean_return"]) == 1.0
