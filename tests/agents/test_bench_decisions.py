"""benchmarks/bench_decisions.py times every decision of any controller spec through the one episode loop."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_decisions import bench_decisions


def test_every_decision_of_every_timed_episode_is_timed():
    result = bench_decisions("pi_feedback", benches=2, first=1)
    assert result["benches"] == [1, 3]
    assert [o["bench"] for o in result["outcomes"]] == [1, 2]
    assert result["decisions"] == sum(o["steps"] for o in result["outcomes"])
    for clock in ("thread_cpu", "wall"):
        times = result[clock]
        assert 0.0 < times["p50_ms"] <= times["p99_ms"] <= times["max_ms"]


def test_a_bad_bench_range_or_controller_is_refused_by_name():
    with pytest.raises(ValueError, match="--benches"):
        bench_decisions("pi_feedback", benches=0)
    with pytest.raises(Exception, match="mpc"):   # the unknown name's message lists the valid ones
        bench_decisions("no_such_controller", benches=1)


def test_a_controller_that_splits_its_period_has_the_part_before_its_command_recorded():
    from bench_decisions import _Timed

    class Split:
        def act(self, obs):
            self.info = {"decision_cpu_s": 2e-4, "period_cpu_s": 5e-4}
            return obs

    timed, plain = _Timed(Split()), _Timed(type("Plain", (), {"act": lambda self, obs: obs})())
    timed.act(0.0)
    plain.act(0.0)
    assert timed.decision_ns == [200_000] and plain.decision_ns == [] and len(plain.cpu_ns) == 1
