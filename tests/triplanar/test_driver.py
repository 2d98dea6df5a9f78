"""The one driver and the one outcome vocabulary: what simulate and the env report, and the event record."""

from __future__ import annotations

import sys
import threading

import numpy as np
import pytest

from triplanar import Effect, Parameter, kernel as K, paper_model, simulate
from triplanar.outcome import EVENT_OUTCOME, Outcome, describe, event_name
from triplanar.result import Event


def test_every_event_has_an_outcome_and_a_name() -> None:
    assert EVENT_OUTCOME.shape == (K.N_EVENTS,)
    assert set(EVENT_OUTCOME.tolist()) <= {int(o) for o in Outcome}
    names = [event_name(k) for k in range(K.N_EVENTS)]
    assert len(set(names)) == K.N_EVENTS  # each event is told apart
    with pytest.raises(ValueError):
        event_name(K.N_EVENTS)


def test_labels_round_trip() -> None:
    for outcome in Outcome:
        assert Outcome.from_label(outcome.label) is outcome


def test_a_travelled_run_records_its_ending_and_counts_its_work() -> None:
    result = simulate(paper_model("A", 40.0))
    assert result.status is Outcome.TRAVEL and result.status.label == "travel" and f"{result.status}" == "travel"
    assert result.events[-1].outcome is Outcome.TRAVEL and result.events[-1].event == K.EV_TRAVEL
    assert result.events[-1].t == result.t[-1]
    assert [e.t for e in result.events] == sorted(e.t for e in result.events)
    # every accepted step is a recorded row (the start is row 0)
    assert result.n_steps == len(result.t) - 1
    # DOPRI5: 6 new stages per step at least, plus the evaluation at each accepted step's end
    assert result.nfev >= 7 * result.n_steps
    assert result.n_starts >= 1
    assert result.message == describe(Outcome.TRAVEL, K.EV_TRAVEL, float(result.t[-1]), 0.08)


class _Pulse(Effect):
    """Test-only: a push at the mass centre for the first 50 ms (a user effect: the Python wrench path)."""
    name = "pulse_for_driver_test"
    parameters = {"force_N": Parameter(20.0, 0.0, 100.0, "N", "pulse along e1")}

    def wrench(self, t, state):
        return (np.array([self["force_N"], 0.0, 0.0]) if t < 0.05 else np.zeros(3)), np.zeros(3)


def test_an_arrest_is_decided_by_the_statics_and_recorded() -> None:
    """Pushed below its threshold by a short pulse, the block slides, slows and is held: the driver asked the
    statics at least once and the record ends with the arrest, a decision of the statics (event -1)."""
    result = simulate(paper_model("B", 15.0, effects=[_Pulse()]), t_max_s=2.0)
    assert result.status is Outcome.ARRESTED, result.message
    assert result.n_statics >= 1
    assert result.events[-1] == Event(float(result.t[-1]), -1, Outcome.ARRESTED)
    assert result.events[-1].name == "arrested"
    assert any(e.outcome is Outcome.SLOW or e.outcome is Outcome.STOPPED for e in result.events[:-1])
    assert simulate(paper_model("B", 40.0), t_max_s=0.05).status is Outcome.TIME_LIMIT


_MEETING: dict[str, threading.Barrier] = {}  # test-only: where two runs wait for each other


class _MeetingPulse(_Pulse):
    """Test-only: a :class:`_Pulse` that, at its first call inside a run, waits until another run in another thread
    has reached the same point, so that both runs are under way at once."""
    name = "meeting_pulse_for_driver_test"

    def wrench(self, t, state):
        barrier = _MEETING.pop(f"{id(self)}", None)
        if t > 0.0 and barrier is not None:
            barrier.wait(timeout=120)
        elif barrier is not None:
            _MEETING[f"{id(self)}"] = barrier
        return super().wrench(t, state)


def test_runs_in_threads_each_call_their_own_user_force() -> None:
    """Two runs with different user forces, under way at the same time in two threads, give each its own trace: the
    user force function travels with the run (kernel.user_force), not through one slot that the later run would
    take over."""
    models = [paper_model("B", 15.0, effects=[_MeetingPulse(force_N=force)]) for force in (20.0, 60.0)]
    alone = [simulate(model, t_max_s=0.3) for model in models]
    assert not np.array_equal(alone[0].y[-1], alone[1].y[-1])
    barrier = threading.Barrier(2)
    for model in models:
        _MEETING[f"{id(model.effects[0])}"] = barrier
    together: list = [None, None]

    def run(i: int) -> None:
        together[i] = simulate(models[i], t_max_s=0.3)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=300)
    assert not barrier.broken and not _MEETING
    for i in range(2):
        assert together[i].status == alone[i].status and np.array_equal(together[i].y, alone[i].y)
    assert not K._USER_FORCES  # every run took its function back


def test_held_block_never_runs_the_driver() -> None:
    result = simulate(paper_model("A", 3.0))
    assert result.status is Outcome.HELD and result.events == () and result.nfev == 0


def test_a_full_buffer_grows_without_changing_the_trace(monkeypatch) -> None:
    """With a 16-row first buffer the driver returns BUFFER_FULL several times and is called again on a larger
    buffer: the trace is bitwise the one recorded in a single call; without room to grow the run fails, saying so."""
    model = paper_model("A", 40.0)
    whole = simulate(model)
    monkeypatch.setattr(sys.modules["triplanar.simulate"], "DOPRI5_FIRST_ROWS", 16)  # (the package's simulate is
    # the function, which hides the module's name)
    grown = simulate(model)
    assert len(whole.t) > 64
    assert grown.status.label == "travel" and np.array_equal(whole.y, grown.y) and np.array_equal(whole.aux, grown.aux)
    assert np.array_equal(whole.dydt, grown.dydt)
    assert grown.events == whole.events and grown.n_steps == whole.n_steps
    assert grown.nfev == whole.nfev + 3  # each of the 3 continuations (16 -> 32 -> 64 -> 128 rows) evaluates f again
    short = simulate(model, max_rows=len(whole.t) - 1)
    assert short.status.label == "failed" and "max_rows" in short.message
