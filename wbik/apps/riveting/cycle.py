"""The riveting run: 300 s of simulated time, cycle after cycle, checked densely for collisions.

Start: the UR5 at its nominal configuration (EuRoC's "posicion inicial"); first move to rivet_home.
Each cycle (ur5-riveting.md 2.3):

1. at rivet_home: load_rivet (a dwell of ``load_s``);
2. the server publishes hole_guess, a noisy pose near one hole (noise model below); the client
   identifies the nearest true hole by position (the thesis's ``detecting_hole_guess``);
3. the planner's moves: to the hole, insert, trigger_rivet (dwell), retract, back to rivet_home.

Hole guesses (our model; the seed gives none): the server picks a hole uniformly among those not
riveted yet (with a seeded numpy Generator), and publishes its frame with the position moved by
isotropic Gaussian noise (``position_sigma`` 4 mm per axis, redrawn while the offset is longer than
``position_max`` = 15 mm, under half the 40 mm hole spacing, so the nearest hole is always right)
and the orientation turned by a Gaussian angle (``angle_sigma_deg`` 2 deg) about a uniformly random
axis. The run ends at ``duration`` (300 s) or when every hole is riveted.

A rivet counts when its trigger comes before the end of the run, the identified hole is the true
one, the tcp at trigger is within ``depth_tolerance`` (0.1 mm) of the 6 mm depth along the hole
axis, within 0.3 mm laterally and 1 deg in axis, and the cycle touched nothing (all distances > 0).

Collision check: every move is sampled so that consecutive samples are at most 2 mm of tcp motion
and 0.01 rad of any joint apart (0.2 mm of tcp motion when the tool is at the hole: insert and
retract), and every sample is measured with coal distance queries (see ``collision``). A collision
is a contact event: a geometry's distance to the workpiece going from > 0 to <= 0.

Planning is charged to the run (``charge_planning``, default on): each hole is planned online,
after hole_guess is known, while the robot waits at rivet_home; a ``plan`` dwell of the plan's
deterministic cost (:mod:`wbik.apps.riveting.cost`: counted operations x calibrated unit costs) is
added to the clock. The measured wall time of the planning is reported beside it, not charged.

The EuRoC client's state machine (:mod:`wbik.apps.riveting.task_states`) drives the run: STARTING ->
GOING_RIVET_HOME (first move, load_rivet) -> DETECTING_HOLE_POSE (identify the hole, plan; the
thesis's move to q_int and sleep) -> GOING_HOLE_GUESS -> MOVING_INTO_HOLE -> RIVETING ->
MOVING_OUT_FROM_HOLE -> GOING_RIVET_HOME (return, load_rivet) -> DETECTING_HOLE_POSE ...; every
move is run in its state (illegal transitions raise) and the visits are recorded with their times.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import TOOL_GEOMETRIES
from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.moves import Move
from wbik.apps.riveting.moves import dwell
from wbik.apps.riveting.moves import sample_times
from wbik.apps.riveting.plan import TRIGGER
from wbik.apps.riveting.plan import Insertion
from wbik.apps.riveting.plan import Planner
from wbik.apps.riveting.plan import tcp_errors
from wbik.apps.riveting.scene import Hole
from wbik.apps.riveting.scene import Scene
from wbik.apps.riveting.scoring import score
from wbik.apps.riveting.task_states import State
from wbik.apps.riveting.task_states import TaskStateMachine
from wbik.apps.riveting.task_states import state_of_move


@dataclass(frozen=True)
class NoiseModel:
    """hole_guess noise: position (m) and orientation (deg) perturbations of the true hole frame."""

    position_sigma: float = 0.004
    position_max: float = 0.015
    angle_sigma_deg: float = 2.0

    def guess(self, hole: Hole, rng: np.random.Generator) -> pin.SE3:
        while True:
            offset = rng.normal(0.0, self.position_sigma, 3)
            if np.linalg.norm(offset) <= self.position_max:
                break
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = np.radians(rng.normal(0.0, self.angle_sigma_deg))
        rotation = pin.exp3(axis * angle) @ hole.placement.rotation
        return pin.SE3(rotation, hole.position + offset)


@dataclass(frozen=True)
class RunConfig:
    duration: float = 300.0
    seed: int = 2015
    max_cycles: int | None = None
    noise: NoiseModel = NoiseModel()
    depth_tolerance: float = 1e-4
    lateral_tolerance: float = 3e-4
    angle_tolerance_deg: float = 1.0
    keep_trajectory: bool = True
    charge_planning: bool = True


@dataclass
class MoveCheck:
    """Dense check of one move: samples, minimum distances (m) and contact events."""

    samples: int
    tool_min: float
    link_min: float
    table_min: float
    collisions: int
    colliding: list[str] = field(default_factory=list)


@dataclass
class RunResult:
    planner: str
    cycles: list[dict]
    setup: dict
    rivets: int
    collisions: int
    end_time: float
    timeline: list[tuple[float, Move]]
    wall_time_s: float
    first_move: dict
    states: TaskStateMachine = field(default_factory=TaskStateMachine)
    all_riveted_s: float | None = None

    def summary(self) -> dict:
        cycles = [c for c in self.cycles if c.get("trigger_time_s") is not None]
        positions = [c["position_error_m"] for c in cycles]
        angles = [c["axis_error_rad"] for c in cycles]
        result = score(positions, angles, self.rivets, self.collisions)
        durations = [c["cycle_time_s"] for c in self.cycles if c.get("success")]
        all_cycles = self.cycles

        def smallest(key):
            values = [c[key] for c in all_cycles if c.get(key) is not None]
            return float(min(values)) if values else None

        return {
            "planner": self.planner,
            "rivets": self.rivets,
            "cycles": len(self.cycles),
            "collisions": self.collisions,
            "score": result.as_dict(),
            "mean_localisation_error_mm": float(np.mean(positions) * 1e3) if positions else None,
            "mean_axis_error_deg": float(np.degrees(np.mean(angles))) if angles else None,
            "max_lateral_error_mm": (float(max(c["lateral_error_m"] for c in cycles) * 1e3)
                                     if cycles else None),
            "max_depth_error_mm": (float(max(abs(c["depth_error_m"]) for c in cycles) * 1e3)
                                   if cycles else None),
            "min_clearance_tool_mm": _mm(smallest("tool_min_m")),
            "min_clearance_links_mm": _mm(smallest("link_min_m")),
            "min_clearance_table_mm": _mm(smallest("table_min_m")),
            "mean_cycle_time_s": float(np.mean(durations)) if durations else None,
            "min_cycle_time_s": float(np.min(durations)) if durations else None,
            "max_cycle_time_s": float(np.max(durations)) if durations else None,
            "simulated_time_s": self.end_time,
            "failed_plans": sum(1 for c in self.cycles if not c.get("success")),
            "planning_time_s": float(sum(c.get("planning_time_s", 0.0) for c in self.cycles)),
            "planning_cost_s": float(sum(c.get("planning_cost_s", 0.0) for c in self.cycles)),
            "planning_charged_s": float(sum(c.get("planning_charged_s", 0.0) for c in self.cycles)),
            "all_holes_riveted_s": self.all_riveted_s,
            "states_visited": self.states.counts(),
            "wall_time_s": self.wall_time_s,
        }


def _mm(value: float | None) -> float | None:
    return None if value is None else value * 1e3


def check_move(move: Move, chain, collision: CollisionModel, previous: dict[str, float]) -> MoveCheck:
    """Sample a move densely and measure every sample; ``previous`` carries the last distance per
    geometry across moves (for contact events)."""
    times = sample_times(move, chain)
    tool_min = link_min = table_min = np.inf
    events, colliding = 0, []
    for t in times:
        clearance = collision.clearance(move.evaluate(t)[0])
        for item in clearance.workpiece:
            if item.distance <= 0.0 and previous.get(item.geometry, 1.0) > 0.0:
                events += 1
                colliding.append(item.geometry)
            previous[item.geometry] = item.distance
            if item.geometry in TOOL_GEOMETRIES:
                tool_min = min(tool_min, item.distance)
            else:
                link_min = min(link_min, item.distance)
        table_min = min(table_min, clearance.table_minimum())
    return MoveCheck(len(times), float(tool_min), float(link_min), float(table_min), events, colliding)


def simulate(planner: Planner, scene: Scene, collision: CollisionModel, insertion: Insertion,
             q_home: np.ndarray, config: RunConfig = RunConfig(),
             on_cycle: Callable[[RunResult], None] | None = None) -> RunResult:
    """Run the riveting task with ``planner``; ``on_cycle`` sees the result so far after each cycle."""
    started = time.perf_counter()
    chain = planner.chain
    rng = np.random.default_rng(config.seed)
    setup = planner.setup(q_home)
    previous: dict[str, float] = {}
    timeline: list[tuple[float, Move]] = []
    clock = 0.0
    states = TaskStateMachine(0.0)
    states.go(State.GOING_RIVET_HOME, clock)  # target_frame == /rivet_home
    first = planner.go_home(planner.robot.nominal.copy(), q_home)
    first_checks = [check_move(move, chain, collision, previous) for move in first]
    for move in first:
        timeline.append((clock, move))
        clock += move.duration
    first_collisions = sum(c.collisions for c in first_checks)
    result = RunResult(planner.name, [], setup, 0, first_collisions, clock, timeline, 0.0,
                       {"duration_s": clock, "collisions": first_collisions}, states)
    remaining = list(scene.holes)
    loaded = False
    while clock < config.duration and remaining:
        if config.max_cycles is not None and len(result.cycles) >= config.max_cycles:
            break
        cycle_start = clock
        visits_before = len(states.visits)
        moves: list[Move] = []
        if not loaded:  # GOING_RIVET_HOME ends at rivet_home with load_rivet
            moves.append(dwell("load_rivet", q_home, insertion.load_s))
            loaded = True
        true_hole = remaining[int(rng.integers(len(remaining)))]
        guess = config.noise.guess(true_hole, rng)
        identified = scene.nearest_hole(guess.translation)
        plan = planner.plan(identified, q_home)
        charged = plan.planning_cost_s if config.charge_planning else 0.0
        record = {"hole": true_hole.name, "face": true_hole.face, "identified": identified.name,
                  "guess_offset_mm": float(np.linalg.norm(guess.translation - true_hole.position) * 1e3),
                  "start_time_s": cycle_start, "success": plan.success, "reason": plan.reason,
                  "planning_time_s": plan.planning_time_s, "planning_cost_s": plan.planning_cost_s,
                  "planning_charged_s": charged, **{k: v for k, v in plan.info.items()}}
        remaining.remove(true_hole)
        if charged > 0.0:
            moves.append(dwell("plan", q_home, charged))
        if plan.success:
            moves += plan.moves
        checks, trigger_time, q_trigger = [], None, None
        detected = False
        for move in moves:
            if move.name != "load_rivet" and not detected:
                # target_frame == /hole_guess: detecting_hole_guess() (a retry after a failed plan)
                states.go(State.DETECTING_HOLE_POSE, clock, retry=states.state == State.DETECTING_HOLE_POSE)
                detected = True
            states.go(state_of_move(move.name), clock)
            checks.append(check_move(move, chain, collision, previous))
            if move.name == TRIGGER:
                trigger_time, q_trigger = clock, move.hold
            if config.keep_trajectory:
                timeline.append((clock, move))
            clock += move.duration
        if not detected:
            states.go(State.DETECTING_HOLE_POSE, clock, retry=states.state == State.DETECTING_HOLE_POSE)
        if states.state == State.GOING_RIVET_HOME:
            loaded = False  # back at rivet_home: load_rivet before the next hole
        if not plan.success:
            record.update({"cycle_time_s": clock - cycle_start,
                           "states": [name for _, name in states.visits[visits_before:]]})
            result.cycles.append(record)
            result.end_time = min(clock, config.duration)
            continue
        collisions = sum(check.collisions for check in checks)
        wanted = insertion.inserted_pose(true_hole)
        position, lateral, along, angle = tcp_errors(chain, q_trigger, wanted)
        in_time = trigger_time is not None and trigger_time <= config.duration
        correct = (in_time and identified.name == true_hole.name and abs(along) <= config.depth_tolerance
                   and lateral < config.lateral_tolerance and np.degrees(angle) < config.angle_tolerance_deg
                   and collisions == 0)
        record.update({
            "trigger_time_s": trigger_time if in_time else None, "cycle_time_s": clock - cycle_start,
            "position_error_m": position, "lateral_error_m": lateral, "depth_error_m": along,
            "axis_error_rad": angle, "collisions": collisions,
            "colliding": sorted({name for check in checks for name in check.colliding}),
            "tool_min_m": min(c.tool_min for c in checks), "link_min_m": min(c.link_min for c in checks),
            "table_min_m": min(c.table_min for c in checks), "samples": sum(c.samples for c in checks),
            "moves": {move.name: round(move.duration, 4) for move in moves},
            "states": [name for _, name in states.visits[visits_before:]],
            "counted": bool(correct)})
        result.cycles.append(record)
        result.rivets += int(correct)
        result.collisions += collisions
        result.end_time = min(clock, config.duration)
        result.wall_time_s = time.perf_counter() - started
        if on_cycle is not None:
            on_cycle(result)
    if not remaining and all(c.get("counted") for c in result.cycles) and clock <= config.duration:
        result.all_riveted_s = clock
    result.end_time = min(clock, config.duration) if remaining else clock
    result.wall_time_s = time.perf_counter() - started
    return result
