"""The riveting run: cycles for ``duration`` s of simulated time, driven by the EuRoC client's state machine.
A cycle: load_rivet; hole_guess (a remaining hole drawn by the seeded rng, its frame perturbed by
``NoiseModel``); the plan for the nearest hole, charged as a ``plan`` dwell of its counted cost; the moves.
A rivet counts when triggered in time in the true hole within the tolerances with no contact event."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.moves import Move, dwell, samples
from wbik.apps.riveting.plan import TRIGGER, Insertion, Planner, tcp_errors
from wbik.apps.riveting.scene import Hole, Scene
from wbik.apps.riveting.scoring import score
from wbik.apps.riveting.task_states import State, TaskStateMachine, state_of_move


@dataclass(frozen=True)
class NoiseModel:
    """hole_guess noise: position (m) and orientation (deg) perturbations of the true hole frame."""

    position_sigma: float = 0.004
    position_max: float = 0.015
    angle_sigma_deg: float = 2.0

    def guess(self, hole: Hole, rng: np.random.Generator) -> pin.SE3:
        offset = rng.normal(0.0, self.position_sigma, 3)
        while np.linalg.norm(offset) > self.position_max:
            offset = rng.normal(0.0, self.position_sigma, 3)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = np.radians(rng.normal(0.0, self.angle_sigma_deg))
        return pin.SE3(pin.exp3(axis * angle) @ hole.placement.rotation, hole.position + offset)


@dataclass(frozen=True)
class RunConfig:
    """Simulated time (s), seed, cycle cap, hole_guess noise and what counts as a rivet (m, deg)."""

    duration: float = 300.0
    seed: int = 2015
    max_cycles: int | None = None
    noise: NoiseModel = NoiseModel()
    depth_tolerance: float = 1e-4
    lateral_tolerance: float = 3e-4
    angle_tolerance_deg: float = 1.0
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
    """One planner's run: its cycles' records, counts, timeline [(start s, move)] and state visits."""

    planner: str
    cycles: list[dict]
    setup: dict
    rivets: int
    collisions: int
    end_time: float
    timeline: list[tuple[float, Move]]
    wall_time_s: float
    states: TaskStateMachine = field(default_factory=TaskStateMachine)
    all_riveted_s: float | None = None

    def summary(self) -> dict:
        cycles = [c for c in self.cycles if c.get("trigger_time_s") is not None]
        positions = [c["position_error_m"] for c in cycles]
        angles = [c["axis_error_rad"] for c in cycles]
        durations = [c["cycle_time_s"] for c in self.cycles if c.get("success")]

        def stat(values: list, function, scale: float = 1e3) -> float | None:
            return float(function(values)) * scale if values else None

        def smallest_mm(key: str) -> float | None:
            return stat([c[key] for c in self.cycles if c.get(key) is not None], min)

        def total(key: str) -> float:
            return float(sum(c.get(key, 0.0) for c in self.cycles))

        return {
            "planner": self.planner, "rivets": self.rivets, "cycles": len(self.cycles),
            "collisions": self.collisions,
            "score": score(positions, angles, self.rivets, self.collisions).as_dict(),
            "mean_localisation_error_mm": stat(positions, np.mean),
            "mean_axis_error_deg": float(np.degrees(np.mean(angles))) if angles else None,
            "max_lateral_error_mm": stat([c["lateral_error_m"] for c in cycles], max),
            "max_depth_error_mm": stat([abs(c["depth_error_m"]) for c in cycles], max),
            "min_clearance_tool_mm": smallest_mm("tool_min_m"),
            "min_clearance_links_mm": smallest_mm("link_min_m"),
            "min_clearance_table_mm": smallest_mm("table_min_m"),
            "mean_cycle_time_s": stat(durations, np.mean, 1.0),
            "min_cycle_time_s": stat(durations, np.min, 1.0),
            "max_cycle_time_s": stat(durations, np.max, 1.0),
            "simulated_time_s": self.end_time,
            "failed_plans": sum(1 for c in self.cycles if not c.get("success")),
            "planning_time_s": total("planning_time_s"),
            "planning_cost_s": total("planning_cost_s"),
            "planning_charged_s": total("planning_charged_s"),
            "all_holes_riveted_s": self.all_riveted_s,
            "states_visited": self.states.counts(),
            "wall_time_s": self.wall_time_s,
        }


def check_move(move: Move, chain, collision: CollisionModel, previous: dict[str, bool]) -> MoveCheck:
    """Measure a move's samples; ``previous``: whether each geometry was clear at the last sample (a
    contact event is clear, then touching)."""
    times, rows = samples(move, chain)
    tool_min = link_min = table_min = np.inf
    colliding = []
    for q in rows:
        clearance = collision.clearance(q)
        touching = clearance.touching()
        colliding += [name for name in touching if previous.get(name, True)]
        previous.update({entry.name: entry.name not in touching for entry in clearance.entries})
        tool_min = clearance.minimum("tool", tool_min)
        link_min = clearance.minimum("links", link_min)
        table_min = clearance.minimum("table", table_min)
    return MoveCheck(len(times), tool_min, link_min, table_min, len(colliding), colliding)


def simulate(planner: Planner, scene: Scene, collision: CollisionModel, insertion: Insertion,
             q_home: np.ndarray, config: RunConfig = RunConfig(),
             on_cycle: Callable[[RunResult], None] | None = None) -> RunResult:
    """Run the riveting task with ``planner``; ``on_cycle`` sees the result so far after each cycle."""
    started = time.perf_counter()
    chain = planner.chain
    rng = np.random.default_rng(config.seed)
    setup = planner.setup(q_home)
    previous: dict[str, bool] = {}
    states = TaskStateMachine(0.0)
    timeline: list[tuple[float, Move]] = []
    clock = 0.0

    def run(moves: list[Move]) -> list[MoveCheck]:
        nonlocal clock
        checks = []
        for move in moves:
            states.go(state_of_move(move.name), clock)
            checks.append(check_move(move, chain, collision, previous))
            timeline.append((clock, move))
            clock += move.duration
        return checks

    collisions = sum(check.collisions for check in run(planner.go_home(planner.robot.nominal.copy(), q_home)))
    result = RunResult(planner.name, [], setup, 0, collisions, clock, timeline, 0.0, states)
    remaining = list(scene.holes)
    loaded = False
    while clock < config.duration and remaining:
        if config.max_cycles is not None and len(result.cycles) >= config.max_cycles:
            break
        cycle_start, visits_before, cycle_moves = clock, len(states.visits), len(timeline)
        checks = [] if loaded else run([dwell("load_rivet", q_home, insertion.load_s)])  # at rivet_home
        true_hole = remaining[int(rng.integers(len(remaining)))]
        guess = config.noise.guess(true_hole, rng)
        identified = scene.nearest_hole(guess.translation)
        plan = planner.plan(identified, q_home)
        charged = plan.planning_cost_s if config.charge_planning else 0.0
        record = {"hole": true_hole.name, "face": true_hole.face, "identified": identified.name,
                  "guess_offset_mm": float(np.linalg.norm(guess.translation - true_hole.position) * 1e3),
                  "start_time_s": cycle_start, "success": plan.success, "reason": plan.reason,
                  "planning_time_s": plan.planning_time_s, "planning_cost_s": plan.planning_cost_s,
                  "planning_charged_s": charged, **plan.info}
        remaining.remove(true_hole)
        # target_frame == /hole_guess: detecting_hole_guess(), a retry after a failed plan
        states.go(State.DETECTING_HOLE_POSE, clock, retry=states.state == State.DETECTING_HOLE_POSE)
        planning = [dwell("plan", q_home, charged)] if charged > 0.0 else []
        checks += run(planning + (plan.moves if plan.success else []))
        loaded = states.state != State.GOING_RIVET_HOME  # back at rivet_home: load_rivet before the next hole
        visited = [name for _, name in states.visits[visits_before:]]
        result.cycles.append(record)
        result.end_time = min(clock, config.duration)
        if not plan.success:
            record.update({"cycle_time_s": clock - cycle_start, "states": visited})
            continue
        moves = timeline[cycle_moves:]
        trigger_time, trigger = next((start, move) for start, move in moves if move.name == TRIGGER)
        collisions = sum(check.collisions for check in checks)
        position, lateral, along, angle = tcp_errors(chain, trigger.hold, insertion.inserted_pose(true_hole))
        in_time = trigger_time <= config.duration
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
            "moves": {move.name: round(move.duration, 4) for _, move in moves},
            "states": visited, "counted": bool(correct)})
        result.rivets += int(correct)
        result.collisions += collisions
        result.wall_time_s = time.perf_counter() - started
        if on_cycle is not None:
            on_cycle(result)
    if not remaining and all(c.get("counted") for c in result.cycles) and clock <= config.duration:
        result.all_riveted_s = clock
    result.end_time = min(clock, config.duration) if remaining else clock
    result.wall_time_s = time.perf_counter() - started
    return result
