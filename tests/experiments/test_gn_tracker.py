"""experiments.gn_tracker's command refuses what it cannot run, naming the option."""

from __future__ import annotations

import pytest

from experiments.gn_tracker import main


def test_the_command_refuses_a_bad_truth_window(capsys):
    with pytest.raises(SystemExit):
        main(["judge", "--run", "nowhere", "--truth", "5,2"])
    assert "--truth" in capsys.readouterr().err


@pytest.mark.parametrize("argv, named", [(["--worker", "0"], "--worker"),
                                         (["--worker", "3500", "--truth", "0,16"], "--worker"),
                                         (["--shed-after", "2"], "--shed-after"),
                                         (["--worker", "3500", "--shed-after", "-1"], "--shed-after")])
def test_the_command_refuses_a_bad_worker(capsys, argv, named):
    with pytest.raises(SystemExit):
        main(["judge", "--run", "nowhere", *argv])
    assert named in capsys.readouterr().err
