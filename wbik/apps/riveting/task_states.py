"""The EuRoC client's state machine (ur5-riveting.md 6.4): the thesis's seven states (Annex B) and the seed's
transitions; the cycle runner enters each state before its moves (:func:`state_of_move`)."""

from __future__ import annotations

from enum import IntEnum

from wbik.errors import WbikError


class State(IntEnum):
    STARTING = 1
    GOING_RIVET_HOME = 2
    DETECTING_HOLE_POSE = 3
    GOING_HOLE_GUESS = 4
    MOVING_INTO_HOLE = 5
    RIVETING = 6
    MOVING_OUT_FROM_HOLE = 7


TRANSITIONS: dict[State, tuple[State, ...]] = {
    State.STARTING: (State.GOING_RIVET_HOME,),  # target_frame == /rivet_home
    State.GOING_RIVET_HOME: (State.DETECTING_HOLE_POSE,),  # target_frame == /hole_guess
    State.DETECTING_HOLE_POSE: (State.DETECTING_HOLE_POSE, State.GOING_HOLE_GUESS),  # a retry, or a plan
    State.GOING_HOLE_GUESS: (State.MOVING_INTO_HOLE,),
    State.MOVING_INTO_HOLE: (State.RIVETING,),
    State.RIVETING: (State.MOVING_OUT_FROM_HOLE,),
    State.MOVING_OUT_FROM_HOLE: (State.GOING_RIVET_HOME,),
}  # the allowed successors of each state


class StateTransitionError(WbikError, RuntimeError):
    """A transition the EuRoC state machine does not have."""


MOVE_STATES = {name: state for state, names in (
    (State.GOING_RIVET_HOME, ("to rivet_home", "back to intermediate", "load_rivet")),
    (State.DETECTING_HOLE_POSE, ("plan", "to intermediate", "sleep")),
    (State.GOING_HOLE_GUESS, ("approach",)),
    (State.MOVING_INTO_HOLE, ("insert",)),
    (State.RIVETING, ("trigger_rivet",)),
    (State.MOVING_OUT_FROM_HOLE, ("retract",))) for name in names}  # the state of each move, by its name


def state_of_move(name: str) -> State:
    """The state a move named ``name`` runs in ('approach 2' is an approach)."""
    base = name.rstrip("0123456789 ")
    if base not in MOVE_STATES:
        raise StateTransitionError(f"move {name!r} belongs to no state; known moves: {sorted(MOVE_STATES)}")
    return MOVE_STATES[base]


class TaskStateMachine:
    """The current state, checked transitions and the visits [(time s, state name)]."""

    def __init__(self, time: float = 0.0):
        self.state = State.STARTING
        self.visits: list[tuple[float, str]] = [(float(time), self.state.name)]

    def go(self, state: State, time: float, retry: bool = False) -> None:
        """Enter ``state`` at simulated ``time`` (s); staying is no new visit unless ``retry``."""
        if state == self.state and not retry:
            return
        if state not in TRANSITIONS[self.state]:
            allowed = [s.name for s in TRANSITIONS[self.state]]
            raise StateTransitionError(f"no transition {self.state.name} -> {state.name}; from "
                                       f"{self.state.name} the seed allows {allowed}")
        self.state = state
        self.visits.append((float(time), state.name))

    def counts(self) -> dict[str, int]:
        """Visits per state, in the enum's order."""
        return {state.name: sum(name == state.name for _, name in self.visits) for state in State}
