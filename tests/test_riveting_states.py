"""The EuRoC state machine (seed 002, ur5-riveting.md 6.4) and the deterministic planning cost."""

import numpy as np
import pytest

from wbik.apps.riveting.cost import UNIT_COST_S, PlanningCost
from wbik.apps.riveting.cycle import RunConfig, simulate
from wbik.apps.riveting.ours import QPPlanner
from wbik.apps.riveting.plan import Insertion
from wbik.apps.riveting.task_states import State, StateTransitionError, TaskStateMachine, state_of_move
from wbik.errors import WbikError

CYCLE = [State.DETECTING_HOLE_POSE, State.GOING_HOLE_GUESS, State.MOVING_INTO_HOLE, State.RIVETING,
         State.MOVING_OUT_FROM_HOLE, State.GOING_RIVET_HOME]


def test_seven_states_with_the_seed_values():
    assert [(s.name, s.value) for s in State] == [
        ("STARTING", 1), ("GOING_RIVET_HOME", 2), ("DETECTING_HOLE_POSE", 3), ("GOING_HOLE_GUESS", 4),
        ("MOVING_INTO_HOLE", 5), ("RIVETING", 6), ("MOVING_OUT_FROM_HOLE", 7)]


def test_two_cycles_and_a_retry_follow_the_transitions():
    machine = TaskStateMachine()
    machine.go(State.GOING_RIVET_HOME, 0.0)
    for cycle in range(2):
        for k, state in enumerate(CYCLE):
            machine.go(state, 10.0 * cycle + k)
    machine.go(State.DETECTING_HOLE_POSE, 30.0)
    machine.go(State.DETECTING_HOLE_POSE, 31.0, retry=True)
    counts = machine.counts()
    assert counts["STARTING"] == 1 and counts["RIVETING"] == 2
    assert counts["GOING_RIVET_HOME"] == 3 and counts["DETECTING_HOLE_POSE"] == 4
    assert [t for t, _ in machine.visits] == sorted(t for t, _ in machine.visits)


@pytest.mark.parametrize("start, wrong", [(State.STARTING, State.RIVETING),
                                          (State.GOING_RIVET_HOME, State.MOVING_INTO_HOLE),
                                          (State.RIVETING, State.GOING_RIVET_HOME)])
def test_a_transition_the_seed_does_not_have_raises(start, wrong):
    machine = TaskStateMachine()
    path = [State.GOING_RIVET_HOME, *CYCLE]
    for state in path[:path.index(start) + 1] if start != State.STARTING else []:
        machine.go(state, 0.0)
    with pytest.raises(StateTransitionError) as raised:
        machine.go(wrong, 1.0)
    assert isinstance(raised.value, WbikError)


def test_moves_map_to_their_states():
    assert state_of_move("approach 2") == State.GOING_HOLE_GUESS
    assert state_of_move("to rivet_home 1") == State.GOING_RIVET_HOME
    assert state_of_move("sleep") == State.DETECTING_HOLE_POSE
    assert state_of_move("trigger_rivet") == State.RIVETING
    with pytest.raises(StateTransitionError):
        state_of_move("dance")


def test_planning_cost_is_counts_times_unit_costs():
    cost = PlanningCost()
    cost.add("ik", 3)
    cost.add("clearance", 10)
    assert cost.seconds == pytest.approx(3 * UNIT_COST_S["ik"] + 10 * UNIT_COST_S["clearance"])
    with pytest.raises(WbikError):
        cost.add("coffee")


@pytest.fixture(scope="module")
def cell(riveting_cell):
    robot, scene, collision, _, limits, q_home = riveting_cell
    return robot, scene, collision, limits, q_home


def test_planning_cost_is_deterministic_and_charged_to_the_clock(cell):
    robot, scene, collision, limits, q_home = cell
    planner = QPPlanner(robot, scene, collision, limits, Insertion())
    first, second = planner.plan(scene.hole("h20"), q_home), planner.plan(scene.hole("h20"), q_home)
    assert first.success and first.info["planning_counts"] == second.info["planning_counts"]
    assert first.planning_cost_s == second.planning_cost_s > 0.0
    runs = {charge: simulate(planner, scene, collision, Insertion(), q_home,
                             RunConfig(max_cycles=2, seed=3, charge_planning=charge))
            for charge in (True, False)}
    charged = sum(c["planning_charged_s"] for c in runs[True].cycles)
    assert charged == pytest.approx(sum(c["planning_cost_s"] for c in runs[True].cycles)) and charged > 0
    assert runs[True].end_time - runs[False].end_time == pytest.approx(charged, abs=1e-9)
    assert all(c["planning_charged_s"] == 0.0 for c in runs[False].cycles)
    # the run visits the seed's states in order, each cycle once through
    for cycle in runs[True].cycles:
        assert cycle["states"] == [s.name for s in CYCLE]
    visits = runs[True].states.counts()
    assert visits["STARTING"] == 1 and visits["RIVETING"] == 2 and visits["GOING_RIVET_HOME"] == 3
    assert np.isfinite(runs[True].end_time)
