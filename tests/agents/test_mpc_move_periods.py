"""``mpc``'s bounded estimator (``move_periods``): after its first ``move_periods`` periods the bank neither
resample-moves nor refines (the two steps that replay the whole history, so that no later decision costs more than
one at ``move_periods``); with 0, the default, it does both throughout (tiny settings, a short episode)."""

from __future__ import annotations

import pytest

from agents.heldout import TUNING_SEED, random_benches, run_episode
from agents.mpc import MPCController

TINY = {"bank_size": 4, "elites": 2, "horizon": 8, "hypotheses": 2, "iterations": 1, "refine_evaluations": 2,
        "refine_every": 1, "samples": 8, "start_periods": 2}
SHORT = {"time_limit_s": 0.05}  # 9 decisions


def counts(move_periods: int) -> tuple[int, int, int]:
    bench = random_benches(1, TUNING_SEED, SHORT)[0]
    mpc = MPCController(move_periods=move_periods, **TINY)
    bank_periods = []
    act = mpc.act

    def counted(obs):
        action = act(obs)
        bank_periods.append((len(mpc.bank.history), mpc.bank.refinements, mpc.bank.rejuvenations))
        return action
    mpc.act = counted
    run_episode(mpc, bench, env_kwargs=SHORT)
    return bank_periods


@pytest.mark.slow
def test_the_bank_stops_moving_and_refining_after_move_periods():
    free, bounded = counts(0), counts(3)
    assert len(free) == len(bounded) > 5
    assert free[-1][1] == free[-1][0]  # refined every period (refine_every 1)
    history, refinements, moves = zip(*bounded)
    assert refinements[-1] == 3  # at histories 1, 2 and 3 only
    late = [i for i, h in enumerate(history) if h >= 3]
    assert len({moves[i] for i in late}) == 1 and len({refinements[i] for i in late}) == 1
    assert free[:3] == bounded[:3]  # the same bank until then
