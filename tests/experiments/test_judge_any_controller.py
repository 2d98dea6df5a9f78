"""``python -m experiments.judge``: any controller on the students' judge benches, each a row and several pooled as
seeds of one row (the same benches, the same noise seeds)."""

from __future__ import annotations

import pytest

from experiments import judge as jd


def test_rows_are_judged_on_the_same_benches_and_pooled_as_seeds():
    result = jd.judge_all(["fixed_tip", "pi_feedback"], 2)
    rows, pooled = result["rows"], result["pooled"]
    assert list(rows) == ["fixed_tip", "pi_feedback"] and all(r["n_episodes"] == 2 for r in rows.values())
    assert pooled["n_seeds"] == 2 and pooled["n_benches"] == 2 and pooled["n_episodes"] == 4
    assert rows["fixed_tip"]["score"] == pytest.approx(sum(rows["fixed_tip"]["bench_scores_mm"]) / 2)
    assert pooled["seed_scores_mm"] == pytest.approx([rows["fixed_tip"]["score"], rows["pi_feedback"]["score"]])
    assert pooled["success_rate"] == pytest.approx((rows["fixed_tip"]["success_rate"]
                                                    + rows["pi_feedback"]["success_rate"]) / 2)


def test_a_controller_given_twice_or_unknown_is_refused_by_name(capsys):
    assert jd.main(["--controller", "fixed_tip", "--controller", "fixed_tip", "--n", "1"]) == 2
    assert "'fixed_tip' is given twice" in capsys.readouterr().err
    assert jd.main(["--controller", "no_such", "--n", "1"]) == 2
    assert "pi_feedback" in capsys.readouterr().err
