"""How a run, or one stretch of it, ends: the project's one outcome vocabulary.

:class:`Outcome` names every ending; its ``label`` (the lower-case name: ``"travel"``, ``"arrested"``, ...) is what
results (``SimulationResult.status``), the environment's ``info["reason"]``, the workbench's reports and the CLI
print. Compiled code sees the same values as plain integers (the module constants below, which numba freezes at
compile time). :data:`EVENT_OUTCOME` maps each event of :func:`triplanar.kernel.event_values_ws` to the outcome it
causes, and :func:`describe` words an ending for a person.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

from . import kernel as K


class Outcome(IntEnum):
    """Every way a stretch of integration can end. The first group are physical endings a user sees; the last
    group never leave the compiled code (they tell the driver what to do next)."""

    RUNNING = 0              # not ended: a control period reached its end time (the env goes on)
    TRAVEL = 1               # CP1 moved the travel target along e1 (the test's success)
    LIFT_OFF = 2             # a contact point's normal reaction reached zero
    MASS_CENTRE_OUTSIDE = 3  # the mass centre left the contact triangle seen from above (the block would tip)
    LEFT_PLANE = 4           # a contact point crossed onto another plane
    ARRESTED = 5             # the contact points came to rest and friction holds the block
    FAILED = 6               # the integration failed (singular contact system or step size underflow)
    TIME_LIMIT = 7           # the time limit came first
    HELD = 8                 # friction holds the block from the start: it never slides
    # internal to the compiled code
    SLOW = 9                 # every contact point nearly stopped: the driver asks the statics (arrest or restart)
    STOPPED = 10             # one contact point or the tip stopped slipping: stick or slip anew
    RELEASED = 11            # a stuck contact's or the tip's static friction gave way
    BUFFER_FULL = 12         # the recording buffer is full: the caller gives a larger one and goes on

    @property
    def label(self) -> str:
        """The name results, ``info`` and reports use."""
        return self.name.lower()

    @classmethod
    def from_label(cls, label: str) -> Outcome:
        return cls[label.upper()]

    def __str__(self) -> str:  # printed and formatted as its label ("travel"), not as the integer compiled code sees
        return self.label

    def __format__(self, spec: str) -> str:
        return format(self.label, spec)


# Plain integers for compiled code, checked against the enumeration so the two cannot drift apart.
(RUNNING, TRAVEL, LIFT_OFF, MASS_CENTRE_OUTSIDE, LEFT_PLANE, ARRESTED, FAILED, TIME_LIMIT, HELD, SLOW, STOPPED,
 RELEASED, BUFFER_FULL) = (int(member) for member in Outcome)
assert all(globals()[member.name] == member for member in Outcome)

# -- events -> outcomes ------------------------------------------------------------------------
EVENT_OUTCOME = np.empty(K.N_EVENTS, dtype=np.int64)
EVENT_OUTCOME[K.EV_TRAVEL] = TRAVEL
EVENT_OUTCOME[K.EV_LIFT_OFF:K.EV_LIFT_OFF + 3] = LIFT_OFF
EVENT_OUTCOME[K.EV_MC_OUTSIDE] = MASS_CENTRE_OUTSIDE
EVENT_OUTCOME[K.EV_LEFT_PLANE:K.EV_LEFT_PLANE + 6] = LEFT_PLANE
EVENT_OUTCOME[K.EV_SLOW] = SLOW
EVENT_OUTCOME[K.EV_STOP:K.EV_STOP + 3] = STOPPED
EVENT_OUTCOME[K.EV_RELEASE] = RELEASED
EVENT_OUTCOME[K.EV_TIP_STOP] = STOPPED
EVENT_OUTCOME[K.EV_TIP_RELEASE] = RELEASED
EVENT_OUTCOME.setflags(write=False)

# The plane-crossing events in order: contact point i under plane j, i != j.
LEFT_PLANE_PAIRS = tuple((i, j) for i in range(3) for j in range(3) if i != j)


def event_name(event: int) -> str:
    """A person's name for event ``event`` of :func:`triplanar.kernel.event_values_ws`."""
    if event == K.EV_TRAVEL:
        return "travel target"
    if K.EV_LIFT_OFF <= event < K.EV_LIFT_OFF + 3:
        return f"CP{event - K.EV_LIFT_OFF + 1} lift-off"
    if event == K.EV_MC_OUTSIDE:
        return "mass centre outside the contact triangle"
    if K.EV_LEFT_PLANE <= event < K.EV_LEFT_PLANE + 6:
        i, j = LEFT_PLANE_PAIRS[event - K.EV_LEFT_PLANE]
        return f"CP{i + 1} onto FP{j + 1}"
    if event == K.EV_SLOW:
        return "all contact points slow"
    if K.EV_STOP <= event < K.EV_STOP + 3:
        return f"CP{event - K.EV_STOP + 1} stopped"
    if event == K.EV_RELEASE:
        return "stuck contact released"
    if event == K.EV_TIP_STOP:
        return "tip slip stopped"
    if event == K.EV_TIP_RELEASE:
        return "stuck tip released"
    raise ValueError(f"no event {event}")


def describe(outcome: Outcome, event: int, t: float, travel_m: float) -> str:
    """One sentence for a person: what ended the run, caused by ``event`` (or -1) at time ``t``."""
    at = f"at t = {t:.4f} s"
    if outcome == Outcome.TRAVEL:
        return f"CP1 moved {travel_m * 100:g} cm along e1 {at}"
    if outcome == Outcome.ARRESTED:
        return f"arrested {at}: the contact points came to rest and friction can hold the block"
    if outcome == Outcome.LIFT_OFF:
        return f"CP{event - K.EV_LIFT_OFF + 1} lost contact (its normal reaction reached zero) {at}"
    if outcome == Outcome.MASS_CENTRE_OUTSIDE:
        return f"the mass centre left the contact triangle (seen from above) {at}: the block would tip"
    if outcome == Outcome.LEFT_PLANE:
        i, j = LEFT_PLANE_PAIRS[event - K.EV_LEFT_PLANE]
        if t == 0.0:
            return (f"CP{i + 1} starts under FP{j + 1}: the (tilted) planes put it more than 0.1 mm across the line "
                    f"where FP{i + 1} and FP{j + 1} meet, so it cannot rest on FP{i + 1}")
        return f"CP{i + 1} crossed onto FP{j + 1} (left its plane over the line where the planes meet) {at}"
    if outcome == Outcome.TIME_LIMIT:
        return f"time limit reached {at} before the travel target"
    return f"integration failed {at} (singular contact system or step size underflow)"
