"""``triplanar evaluate`` checks its numbers before any episode: each seed once (a repeated seed would count the
same episodes again and narrow the intervals), seeds in a generator's range, ``--n`` bounded."""

from __future__ import annotations

import pytest

from triplanar import cli

pytest.importorskip("stable_baselines3")


@pytest.mark.parametrize("argv, message", [
    (["--seeds", "0", "0", "0"], "--seeds: seed(s) 0 given more than once"),
    (["--seeds", "1", "2", "1"], "--seeds: seed(s) 1 given more than once"),
    (["--seeds", "-1"], "--seeds: expected integers in [0, 4294967295]"),
    (["--n", "99999999999999999999"], "--n: expected a number of benches in [1, 100000]"),
])
def test_evaluate_refuses_repeated_seeds_and_unbounded_counts(argv, message, tmp_path, capsys) -> None:
    out = tmp_path / "out"
    assert cli.main(["evaluate", "--controller", "steel_tip", *argv, "--out", str(out), "--executor", "serial"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()
