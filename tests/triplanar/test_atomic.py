"""Output files are written completely or not at all: ``triplanar.atomic.write_atomic`` and the writers built on it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import pytest

from triplanar.atomic import MARK, remove_stale_temporaries, temporary_path, write_atomic
from triplanar.plotting import save_figure


class Interrupted(Exception):
    pass


def _half_then_fail(tmp: Path) -> None:
    tmp.write_text("half a fi")
    raise Interrupted("killed mid-write")


def test_writes_the_content_and_leaves_no_temporary(tmp_path) -> None:
    target = tmp_path / "table.csv"
    write_atomic(target, lambda tmp: tmp.write_text("a,b\n1,2\n"))
    assert target.read_text() == "a,b\n1,2\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_a_failed_write_leaves_the_previous_file(tmp_path) -> None:
    target = tmp_path / "report.json"
    target.write_text('{"old": 1}\n')
    with pytest.raises(Interrupted):
        write_atomic(target, _half_then_fail)
    assert target.read_text() == '{"old": 1}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_a_failed_write_creates_nothing(tmp_path) -> None:
    with pytest.raises(Interrupted):
        write_atomic(tmp_path / "new.txt", _half_then_fail)
    assert list(tmp_path.iterdir()) == []


def test_the_temporary_is_hidden_beside_the_target_with_its_suffix_last(tmp_path) -> None:
    seen: list[Path] = []
    write_atomic(tmp_path / "model.zip", lambda tmp: (seen.append(tmp), tmp.write_bytes(b"zip")))
    assert len(seen) == 1 and seen[0].parent == tmp_path and seen[0].name.startswith(".model.")
    assert seen[0].name.endswith(f"{MARK}.zip") and f".{os.getpid()}." in seen[0].name


def test_each_call_gets_its_own_temporary(tmp_path) -> None:
    assert temporary_path(tmp_path / "a.csv") != temporary_path(tmp_path / "a.csv")  # two threads never share one


def _dead_pid() -> int:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    return dead.pid


def test_a_dead_writers_temporaries_are_removed_and_nothing_else(tmp_path) -> None:
    target = tmp_path / "lab.csv"
    dead = _dead_pid()
    stale = temporary_path(target, pid=dead)
    live = temporary_path(target, pid=os.getpid())                      # a writer still running
    other = temporary_path(tmp_path / "lab.csv.truth.json", pid=dead)   # another target's
    near = tmp_path / f".lab.{dead}.partial.csv"                        # not a name temporary_path makes
    for p in (target, stale, live, other, near):
        p.write_text("x")
    remove_stale_temporaries(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in (target, live, other, near))
    remove_stale_temporaries(tmp_path / "lab.csv.truth.json")
    assert not other.exists()


def test_save_figure_writes_a_png_and_closes_the_figure(tmp_path) -> None:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "sub" / "plot.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["plot.png"]
    assert not plt.fignum_exists(fig.number)


def test_save_figure_that_fails_leaves_the_previous_png_and_closes_the_figure(tmp_path, monkeypatch) -> None:
    target = tmp_path / "plot.png"
    target.write_bytes(b"previous")
    fig, _ = plt.subplots()

    def savefig(tmp, **kwargs) -> None:
        Path(tmp).write_bytes(b"\x89PNG half")
        raise Interrupted("disk full")

    monkeypatch.setattr(fig, "savefig", savefig)
    with pytest.raises(Interrupted):
        save_figure(fig, target)
    assert target.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plot.png"]
    assert not plt.fignum_exists(fig.number)
