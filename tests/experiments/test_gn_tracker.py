"""experiments.gn_tracker's command refuses what it cannot run, naming the option."""

from __future__ import annotations

import pytest

from experiments.gn_tracker import main


def test_the_command_refuses_a_bad_truth_window(capsys):
    with pytest.raises(SystemExit):
        main(["judge", "--run", "nowhere", "--truth", "5,2"])
    assert "--truth" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["--worker", "0"], ["--worker", "3500", "--truth", "0,16"]])
def test_the_command_refuses_a_bad_worker(capsys, argv):
    with pytest.raises(SystemExit):
        main(["judge", "--run", "nowhere", *argv])
    assert "--worker" in capsys.readouterr().err
