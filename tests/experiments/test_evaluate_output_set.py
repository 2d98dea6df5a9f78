"""``triplanar evaluate``'s outputs are complete or untouched: ``--out`` checked before any episode, the result set
(CSV, episodes CSV, JSON, plot) replaced as a whole, a killed run's leftovers removed by the next, and one run at a
time into a folder (also for ``train``). The episodes are stubbed: the point is the bookkeeping."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from triplanar import cli
from triplanar.output_set import output_lock

pytest.importorskip("stable_baselines3")
NAMES = ("heldout.csv", "heldout_episodes.csv", "heldout.json", "heldout.png")


@pytest.fixture
def episodes(monkeypatch):
    """``run_part`` stubbed: each part's benches succeed with an error of 0.5 mm; the calls are counted."""
    import experiments.evaluate as evaluate
    from agents.heldout import Outcome
    calls = []

    def run_part(part):
        calls.append(part)
        return [Outcome(part.batch.label, part.batch.bench_set, i, 30.0, True, "travel", 0.5, 0.01, 1.0, 10)
                for i in range(part.start, part.stop)]
    monkeypatch.setattr(evaluate, "run_part", run_part)
    return calls


def evaluate(out, *extra) -> int:
    return cli.main(["evaluate", "--controller", "steel_tip", "--n", "3", "--executor", "serial", "--out", str(out),
                     *extra])


def test_an_out_that_is_a_file_is_refused_before_any_episode(episodes, tmp_path, capsys) -> None:
    out = tmp_path / "out"
    out.write_text("mine")
    assert evaluate(out) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert episodes == [] and out.read_text() == "mine"


def test_a_failed_write_leaves_the_previous_set_whole(episodes, tmp_path, monkeypatch) -> None:
    out = tmp_path / "out"
    assert evaluate(out) == 0
    (out / "notes.txt").write_text("the user's")
    before = {name: (out / name).read_bytes() for name in NAMES}
    from experiments import bench_plots

    def killed(*args, **kwargs):
        raise KeyboardInterrupt   # as a kill between the tables and the plot
    monkeypatch.setattr(bench_plots, "rows_plot", killed)
    assert evaluate(out, "--n", "5") == 130
    assert {name: (out / name).read_bytes() for name in NAMES} == before
    assert (out / "notes.txt").read_text() == "the user's"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and not [p for p in out.iterdir()
                                                                            if "partial" in p.name]
    monkeypatch.undo()


def test_the_new_set_replaces_the_old_one_and_keeps_other_files(episodes, tmp_path) -> None:
    out = tmp_path / "out"
    assert evaluate(out) == 0
    (out / "notes.txt").write_text("the user's")
    assert evaluate(out, "--n", "5") == 0
    assert json.loads((out / "heldout.json").read_text())["n_benches"] == 5
    assert len((out / "heldout_episodes.csv").read_text().splitlines()) == 6
    assert (out / "notes.txt").read_text() == "the user's"


def test_a_killed_runs_leftovers_are_removed_by_the_next(episodes, tmp_path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    out = tmp_path / "out"
    out.mkdir()
    stale_file = out / f".heldout.{dead}.0123456789ab.partial.csv"
    stale_file.write_bytes(b"")
    stale_set = tmp_path / f".out.{dead}.0123456789ab.partial"
    stale_set.mkdir()
    (stale_set / "heldout.csv").write_text("half")
    assert evaluate(out) == 0
    assert not stale_file.exists() and not stale_set.exists()


@pytest.mark.parametrize("command", [
    ["evaluate", "--controller", "steel_tip", "--n", "3"],
    ["train", "--env", "TriPlanarShear-v1", "--timesteps", "64"],
])
def test_a_second_run_into_the_same_out_is_refused(command, episodes, tmp_path, capsys) -> None:
    out = tmp_path / "out"
    with output_lock(out):
        assert cli.main([*command, "--executor", "serial", "--out", str(out)]) == 2
    assert "another run is writing there" in capsys.readouterr().err
    assert episodes == [] and not out.exists()
