"""A simulated staircase and the thesis's sensor-driven stair behaviour (bioloid.md 5.2, 5.6, 6.5): the
state machine reads the ray-cast Sharp beams and filtered FSRs after every half step and climbs, turns and
goes down; StairReady, UpStair and DownStair are generated whole-body (:func:`stair_phases`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np
import pinocchio as pin

import wbik.apps.bioloid.sensors as sensors
from wbik.apps.bioloid.behaviours import along, both_feet_phases, half_step_phases, turn_phases
from wbik.apps.bioloid.gait import (
    OTHER,
    SIDE_NAME,
    SIDES,
    SOLE,
    GaitParameters,
    start_q,
)
from wbik.apps.bioloid.step_wholebody import (
    current_soles,
    pelvis_rotation,
    solve_phases,
)
from wbik.errors import InvalidConfigurationError, WbikError
from wbik.motion.walking.footsteps import clip_points, sole_points, sole_polygon, yaw_of
from wbik.motion.walking.static_gait import BodyPhase, SampledMotion
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.robot import Robot

SHARP_PROXIMITY_THRESHOLD = 100.0
SHARP_IN_FRONT_THRESHOLD = 120.0
SHARP_DIFFERENCE_THRESHOLD = 15.0
MAX_CLIMBS = 3  # the code climbs while stairCont < 3, then looks for a step down
MAX_TURNS = 3  # turns before a climb (bioloid.md 5.6)
STEP_QTY = 100  # the code's loop count (stepQty): the simulation stops after this many decisions
TURN_MEDIUM_DEG = 10.0  # ours: the Roboplus presets' angle is not in the sources
READY_GAP = 0.005  # m, StairReady brings the toes this close to the riser
HEEL_OVERHANG = 0.010  # m, UpStair puts the heel this far past the step's edge
STEP_CLEARANCE = 0.015  # m, a sole changing level passes this high above the higher tread
DOWN_HEEL_GAP = 0.010  # m, DownStair puts the heel this far past the riser below the nose
DOWN_READY_OVERHANG = 0.015  # m, before DownStair StairReady brings the toes this far over the nose
MIN_FOOTHOLD = 0.05  # m, a sole over a nose stands on at least this much of its length
COM_INSET = 0.025  # m, a step moves the CoM this far into the sole it will stand on (half steps too)
SURFACE_TOLERANCE = 1e-6  # m, a sole corner this close to the surface under it touches it
WALK_CYCLE = ("WalkSR1", "WalkSR2", "WalkSL1", "WalkSL2")
PAIR_END = {"WalkSR1": "WalkSR2", "WalkSL1": "WalkSL2"}


class StairError(WbikError):
    """The simulated robot cannot go on: a foot would hit a riser, or the stairs are not climbed."""


@dataclass(frozen=True)
class Staircase:
    """``steps`` solid steps (m) from the first riser at x = ``start_x``, facing +x, centred on y = 0, the
    last tread a ``top_depth`` platform; ``descend``: the same steps go down after it (CEABOT's test)."""

    steps: int = 3
    height: float = 0.030
    depth: float = 0.160
    start_x: float = 0.160
    top_depth: float = 0.300
    width: float = 0.600
    descend: bool = False

    def __post_init__(self) -> None:
        if int(self.steps) != self.steps or self.steps < 1:
            raise InvalidConfigurationError(f"a staircase needs >= 1 step, got {self.steps}")
        for name in ("height", "depth", "top_depth", "width"):
            if not getattr(self, name) > 0:
                raise InvalidConfigurationError(f"staircase {name} must be > 0, got {getattr(self, name)}")
        if self.depth < 0.1 + HEEL_OVERHANG + READY_GAP:
            raise InvalidConfigurationError(f"a tread of {self.depth} m cannot take the 100 mm sole past the "
                                            "heel overhang")

    def edge_x(self, step: int) -> float:
        """x of the riser (and nose edge) of step ``step`` (1-based) on the way up."""
        return self.start_x + (step - 1) * self.depth

    def far_x(self, step: int) -> float:
        """x where tread ``step`` ends ahead: its nose on the way down, else the top platform's end."""
        top_end = self.start_x + (self.steps - 1) * self.depth + self.top_depth
        return top_end + (self.steps - step) * self.depth if self.descend else top_end

    def tread_z(self, step: int) -> float:
        return step * self.height

    @property
    def end_x(self) -> float:
        return self.far_x(1)

    def boxes(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """(lower corner, upper corner) of each step's solid box, step 1 (the widest) first."""
        half = 0.5 * self.width
        return [(np.array([self.edge_x(i), -half, 0.0]), np.array([self.far_x(i), half, self.tread_z(i)]))
                for i in range(1, self.steps + 1)]

    def step_at(self, x: float) -> int:
        """The level of the tread under x (0: the floor, before or after the structure)."""
        return sum(1 for i in range(1, self.steps + 1) if self.edge_x(i) <= x < self.far_x(i))

    def surface_z(self, x: float) -> float:
        return self.tread_z(self.step_at(x))

    def surface_name(self, x: float) -> str:
        step = self.step_at(x)
        if step == 0:
            return "floor" if x < self.start_x else "floor beyond"
        down = self.descend and step < self.steps and x >= self.far_x(step + 1)
        return f"tread {step}" + (" (way down)" if down else "")

    def raycast(self, origin: np.ndarray, direction: np.ndarray) -> float:
        """Distance (m) along the unit ``direction`` to the first step face hit, inf if none."""
        origin, direction = np.asarray(origin, float), np.asarray(direction, float)
        return min((_ray_box(origin, direction, low, high) for low, high in self.boxes()), default=math.inf)

    def nose_edges(self) -> list[tuple[float, float]]:
        """(x, z) of every nose edge (the risers' tops): up, then down with ``descend``."""
        edges = [(self.edge_x(step), self.tread_z(step)) for step in range(1, self.steps + 1)]
        if self.descend:
            edges += [(self.far_x(step), self.tread_z(step)) for step in range(self.steps, 0, -1)]
        return edges

    def edge_distance(self, corners: np.ndarray) -> float:
        """Distance (m) from a flat sole (4 world corners) to the nearest nose edge not under it."""
        corners = np.asarray(corners, dtype=float)
        z = float(np.mean(corners[:, 2]))
        low, high = float(corners[:, 0].min()), float(corners[:, 0].max())
        best = math.inf
        for x_edge, z_edge in self.nose_edges():
            if low < x_edge < high and z >= z_edge:
                continue
            gap = max(0.0, low - x_edge, x_edge - high)
            best = min(best, math.hypot(gap, z - z_edge))
        return best

    def penetration(self, corners: np.ndarray) -> float:
        """How deep (m, >= 0) the lowest sole corner is below the surface under it."""
        return max(0.0, max(self.surface_z(c[0]) - c[2] for c in np.asarray(corners, dtype=float)))

    def foothold(self, corners: np.ndarray,
                 tolerance: float = SURFACE_TOLERANCE) -> tuple[str, float | None] | None:
        """(surface under the heel, x of the nose edge under the toes or None), or None when the sole
        does not stand (in the air, tilted, over a higher surface)."""
        corners = np.asarray(corners, dtype=float)
        z = float(np.mean(corners[:, 2]))
        if np.ptp(corners[:, 2]) > tolerance:
            return None
        heel = corners[np.argmin(corners[:, 0]), 0]
        if abs(self.surface_z(heel) - z) > tolerance:
            return None
        if any(self.surface_z(c[0]) > z + tolerance for c in corners):
            return None
        if all(abs(self.surface_z(c[0]) - z) <= tolerance for c in corners):
            return self.surface_name(heel), None
        edge = min(x for x, edge_z in self.nose_edges() if x > heel and abs(edge_z - z) <= tolerance)
        return self.surface_name(heel), edge


def _ray_box(origin: np.ndarray, direction: np.ndarray, low: np.ndarray, high: np.ndarray) -> float:
    """Slab test: distance to the box along the ray (inf when missed or behind; 0 when inside)."""
    near, far = -math.inf, math.inf
    for axis in range(3):
        if abs(direction[axis]) < 1e-12:
            if not low[axis] <= origin[axis] <= high[axis]:
                return math.inf
            continue
        t1 = (low[axis] - origin[axis]) / direction[axis]
        t2 = (high[axis] - origin[axis]) / direction[axis]
        near, far = max(near, min(t1, t2)), min(far, max(t1, t2))
    if near > far or far < 0:
        return math.inf
    return max(near, 0.0)


class Decision(NamedTuple):
    """The state machine's answer to a read: walk | up | back_then_down | down, and the foot that felt it."""

    action: str
    foot: str | None = None


@dataclass
class StairStateMachine:
    """The code's decisions (bioloid.md 5.6); thresholds compared strictly as listed there."""

    climbs: int = MAX_CLIMBS
    stair_count: int = 0  # stairCont, 0 once the start button is released
    proximity: bool = False
    down: dict = field(default_factory=lambda: {side: sensors.StepDownDetector() for side in SIDES})

    def after_placement(self, sharp: dict[str, float], front_fsr: dict[str, Sequence[float]],
                        forward_foot: str | None = None) -> Decision:
        """One read: Sharp mm and filtered (FSR3, FSR4) per side, the foot in front (None: side by side)."""
        right, left = float(sharp["r"]), float(sharp["l"])
        if right < SHARP_PROXIMITY_THRESHOLD and left < SHARP_PROXIMITY_THRESHOLD:
            self.proximity = True
        if ((right > SHARP_IN_FRONT_THRESHOLD or left > SHARP_IN_FRONT_THRESHOLD)
                and (self.proximity or self.stair_count > 0) and self.stair_count < self.climbs):
            return Decision("up")
        if self.stair_count >= self.climbs:
            for side in SIDES:
                if self.down[side].update(*front_fsr[side]):
                    return Decision("back_then_down" if forward_foot == side else "down", side)
        return Decision("walk")

    @staticmethod
    def turn(sharp: dict[str, float]) -> str | None:
        """diff = right - left: > 15 'right' (RightTurnMedium), < -15 'left', else None."""
        diff = float(sharp["r"]) - float(sharp["l"])
        if not abs(diff) > SHARP_DIFFERENCE_THRESHOLD:
            return None
        return "right" if diff > 0 else "left"

    def climbed(self) -> None:
        self.stair_count += 1
        self.proximity = False

    def descended(self) -> None:
        for detector in self.down.values():
            detector.reset()


def polyline_path(poses: Sequence[pin.SE3]) -> Callable[[float], pin.SE3]:
    """s in [0, 1] -> the pose at fraction s of the polyline through the poses, the first one's rotation."""
    points = np.array([p.translation for p in poses])
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    total = float(lengths.sum())
    if total <= 0:
        raise InvalidConfigurationError("a swing path needs some length")
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    rotation = poses[0].rotation.copy()

    def pose(s: float) -> pin.SE3:
        distance = min(max(s, 0.0), 1.0) * total
        index = min(int(np.searchsorted(cumulative, distance, side="right")) - 1, len(lengths) - 1)
        fraction = 0.0 if lengths[index] == 0 else (distance - cumulative[index]) / lengths[index]
        return pin.SE3(rotation, points[index] + fraction * (points[index + 1] - points[index]))

    return pose


def _moved(placement: pin.SE3, x: float | None = None, z: float | None = None) -> pin.SE3:
    x0, y, z0 = placement.translation
    return pin.SE3(placement.rotation.copy(), np.array([x0 if x is None else x, y, z0 if z is None else z]))


def stair_phases(robot: Robot, soles: dict[str, pin.SE3], stairs: Staircase, step: int, first: str,
                 gait: GaitParameters | None = None, down: bool = False, com_inset: float = COM_INSET
                 ) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """UpStair onto step ``step`` (heels ``HEEL_OVERHANG`` past its edge) or, ``down``, DownStair from it
    (heels ``DOWN_HEEL_GAP`` past the riser below), ``first`` foot first, each swung ``STEP_CLEARANCE``
    above the higher tread, the CoM ``com_inset`` into a sole before the other lifts; the phases and the
    new soles."""
    if down:
        landing_x, z_new = stairs.far_x(step) + DOWN_HEEL_GAP + 0.05, stairs.tread_z(step - 1)
        label, surface = f"DownStair {step}", "the floor" if step == 1 else f"tread {step - 1}"
    else:
        landing_x, z_new = stairs.edge_x(step) + HEEL_OVERHANG + 0.05, stairs.tread_z(step)
        label, surface = f"UpStair {step}", f"tread {step}"
    gait = gait or GaitParameters()
    second = OTHER[first]
    over = max(z_new, float(soles[first].translation[2])) + STEP_CLEARANCE
    heading = yaw_of(soles[second].rotation)
    rotation = lambda s: pelvis_rotation(heading, gait.pitch)  # noqa: E731
    after = {side: _moved(soles[side], x=landing_x, z=z_new) for side in (first, second)}
    names = [f"{label}: CoM over the {SIDE_NAME[second]} foot", f"{label}: {SIDE_NAME[first]} foot onto "
             f"{surface}", f"{label}: CoM over the {SIDE_NAME[first]} foot",
             f"{label}: {SIDE_NAME[second]} foot onto {surface}", f"{label}: CoM between the feet"]
    paths = [polyline_path([soles[s], _moved(soles[s], z=over), _moved(after[s], z=over), after[s]])
             for s in (first, second)]
    phases = both_feet_phases(robot, soles, after, first, gait, names, paths, [rotation] * 5, 3, 2, com_inset)
    return phases, after


def toes_gap(stairs: Staircase, sole: pin.SE3, down: bool = False) -> float:
    """x distance (m) from the toes to the next riser or, ``down``, to the nose of the tread under the
    heel (negative: the toes are over it); inf when there is none."""
    toes = sole.translation[0] + 0.05 * sole.rotation[0, 0]
    if down:
        level = stairs.step_at(sole.translation[0] - 0.05 * sole.rotation[0, 0])
        return stairs.far_x(level) - toes if stairs.descend and level != 0 else math.inf
    return next((stairs.edge_x(step) - toes for step in range(1, stairs.steps + 1)
                 if stairs.edge_x(step) >= toes - 1e-9), math.inf)


class StairRun:
    """A simulated run (:func:`simulate_stairs`): one record per sample, the states, the reads, the motion."""

    def __init__(self, robot: Robot, stairs: Staircase, gait: GaitParameters, margin: float, backend: str,
                 climbs: int, q0: np.ndarray, com_inset: float = COM_INSET):
        self.robot, self.stairs, self.gait, self.margin, self.backend = robot, stairs, gait, margin, backend
        self.com_inset = com_inset
        self.machine = StairStateMachine(climbs=climbs)
        self.descended = 0
        self.q = q0.copy()
        self.boards = {side: sensors.MovingAverage(3) for side in SIDES}
        self.configurations, self.phase_of, self.phase_names = [q0.copy()], [-1], []
        self.support = [tuple(SOLE[s] for s in SIDES)]
        self.samples, self.states, self.reads = [], [], []
        start = sole_polygon(robot, {SOLE[s]: p for s, p in current_soles(robot, q0).items()})
        self._record(q0, "start", None, {"contact_error_m": 0.0, "contact_error_rad": 0.0,
                                         "limit_excess_rad": 0.0,
                                         "com_margin_m": start.margin_of(robot.center_of_mass(q0)[:2])}, ())

    def soles(self) -> dict[str, pin.SE3]:
        return current_soles(self.robot, self.q)

    def _record(self, q: np.ndarray, state: str, phase: str | None, check: dict,
                swing: Sequence[str]) -> None:
        robot, stairs = self.robot, self.stairs
        placements = current_soles(robot, q)
        corners = {side: sole_points(robot, SOLE[side], placements[side]) for side in SIDES}
        footholds = {side: stairs.foothold(corners[side]) for side in SIDES}
        sharp_true = {side: 1e3 * stairs.raycast(*sensors.sharp_ray(robot, q, SOLE[side])) for side in SIDES}
        contact = [side for side in SIDES if footholds[side] is not None]
        forces = {side: np.zeros(4) for side in SIDES}
        if contact:  # the FSRs over the surface carry the weight, with the nose under a sole over it
            pressed, nose = [], []
            for side in contact:
                placement = placements[side]
                points = (sensors.robot_fsr_positions(robot, SOLE[side]) @ placement.rotation.T
                          + placement.translation)
                edge = footholds[side][1]
                pressed += [(side, index, point) for index, point in enumerate(points)
                            if edge is None or point[0] <= edge]
                if edge is not None:  # the sole rests on the nose: where its sides cross the edge line
                    nose += [p for p in clip_points(corners[side][:, :2], edge) if abs(p[0] - edge) < 1e-12]
            supports = np.array([p[:2] for _, _, p in pressed] + nose)
            loads = sensors.support_loads(supports, robot.mass * sensors.GRAVITY, robot.center_of_mass(q)[:2])
            for (side, index, _), load in zip(pressed, loads[:len(pressed)], strict=True):
                forces[side][index] = load
        fsr = {side: self.boards[side].add(sensors.fsr_reading_mv(forces[side])) for side in SIDES}
        swing_sole = [s for s in SIDES if SOLE[s] in swing and footholds[s] is None]  # in the air
        self.samples.append({
            "state": state, "phase": phase, "support": sorted(SOLE[s] for s in contact),
            "surfaces": {SOLE[s]: None if footholds[s] is None else footholds[s][0] for s in SIDES},
            "sharp_mm": {SOLE[s]: float(sensors.sharp_reading_mm(sharp_true[s])) for s in SIDES},
            "sharp_true_mm": {SOLE[s]: sharp_true[s] if math.isfinite(sharp_true[s]) else None
                              for s in SIDES},
            "fsr_mv": {SOLE[s]: fsr[s].tolist() for s in SIDES},
            "com_margin_m": check["com_margin_m"],
            "clearance_m": min((stairs.edge_distance(corners[s]) for s in swing_sole), default=None),
            "penetration_m": max(stairs.penetration(corners[s]) for s in SIDES),
            "contact_error_m": check["contact_error_m"], "contact_error_rad": check["contact_error_rad"],
            "limit_excess_rad": check["limit_excess_rad"],
            "swing": [SOLE[s] for s in swing_sole]})

    def _foothold(self, sole: str, placement: pin.SE3) -> tuple[str, float | None]:
        corners = sole_points(self.robot, sole, placement)
        found = self.stairs.foothold(corners, 1e-9)
        if found is not None and found[1] is not None and found[1] - corners[:, 0].min() < MIN_FOOTHOLD:
            found = None
        if found is None:
            raise StairError(f"the {sole} would be off a surface (into a riser, or over a nose by more than "
                             f"{0.1 - MIN_FOOTHOLD:.3f} m) at x = {placement.translation[0]:.3f} m")
        return found

    def solve(self, state: str, phases: list[BodyPhase], soles_after: dict[str, pin.SE3]) -> None:
        """Check the footholds, solve the phases (a sole over a nose supports behind it) and record."""
        for side, placement in soles_after.items():
            try:
                self._foothold(SOLE[side], placement)
            except StairError as error:
                raise StairError(f"{state}: {error}") from None
        for phase in phases:
            for sole, placement in phase.stance.items():
                edge = self._foothold(sole, placement)[1]
                if edge is not None:
                    phase.clip_x[sole] = edge
        self.states.append(state)
        result = solve_phases(self.robot, self.q, phases, self.margin, self.backend, name=state)
        motion = result.motion
        for q, check in zip(motion.q[1:], result.checks, strict=True):
            phase = phases[check["phase"]]
            self._record(q, state, phase.name, check, tuple(phase.swing))
        self.configurations += list(motion.q[1:])
        self.phase_of += [len(self.phase_names) + index for index in motion.phase[1:]]
        self.phase_names += motion.phase_names
        self.support += motion.support[1:]
        self.q = motion.q[-1].copy()

    def read(self, after: str) -> dict:
        last = self.samples[-1]
        ahead = along(self.soles(), "r")
        entry = {"after": after, "sharp_mm": {s: last["sharp_mm"][SOLE[s]] for s in SIDES},
                 "front_fsr_mv": {s: last["fsr_mv"][SOLE[s]][2:] for s in SIDES},
                 "forward_foot": None if abs(ahead) < 1e-4 else ("r" if ahead > 0 else "l"),
                 "stair_count": self.machine.stair_count, "proximity": self.machine.proximity}
        self.reads.append(entry)
        return entry

    def half(self, name: str, length: float | None = None) -> None:
        phases, after = half_step_phases(self.robot, self.soles(), name, self.gait, length,
                                         inset=self.com_inset)
        self.solve(name, phases, after)

    def stair_ready(self, cycle: int, down: bool) -> bool:
        """Our StairReady: two half steps bringing the toes ``READY_GAP`` from the riser or, ``down``,
        ``DOWN_READY_OVERHANG`` over the nose, unless they are there; whether it stepped."""
        gaps = [toes_gap(self.stairs, sole, down) for sole in self.soles().values()]
        if down:
            gap = max(gaps)
            length, needed, missing = gap + DOWN_READY_OVERHANG, gap > -DOWN_READY_OVERHANG + 1e-4, "nose"
        else:
            gap = min(gaps)
            length, needed, missing = gap - READY_GAP, gap > READY_GAP + 1e-4, "riser"
        if not math.isfinite(gap):
            raise StairError(f"{'DownStair' if down else 'StairReady'}: no {missing} ahead of the feet")
        if needed:
            first = _leading_foot(cycle).upper()
            self.states.append("StairReady")
            self.half(f"WalkS{first}1", length=length)
            self.half(f"WalkS{first}2")
        return needed

    @property
    def climbed(self) -> int:
        return self.machine.stair_count

    @property
    def reached_top(self) -> bool:
        return self.climbed == self.stairs.steps

    @property
    def reached_bottom(self) -> bool:
        return self.stairs.descend and self.descended == self.stairs.steps

    def scene_boxes(self) -> tuple:
        from wbik.viz.environment import STAIR_COLORS, SceneBox

        return tuple(SceneBox.between(f"stair step {index + 1}", low, high,
                                      color=STAIR_COLORS[min(index, len(STAIR_COLORS) - 1)])
                     for index, (low, high) in enumerate(self.stairs.boxes()))

    def summary(self) -> dict:
        swing = [s["clearance_m"] for s in self.samples if s["clearance_m"] is not None]
        solved = [s for s in self.samples if s["state"] != "start"]
        return {
            "samples": len(solved), "steps": self.stairs.steps, "climbed": self.climbed,
            "reached_top": self.reached_top, "descended": self.descended,
            "reached_bottom": self.reached_bottom,
            "states_visited": list(dict.fromkeys(self.states)),
            "behaviours_run": len(self.states),
            "max_contact_error_m": max(s["contact_error_m"] for s in solved),
            "max_contact_error_rad": max(s["contact_error_rad"] for s in solved),
            "min_com_margin_m": min(s["com_margin_m"] for s in solved),
            "max_limit_excess_rad": max(s["limit_excess_rad"] for s in solved),
            "min_clearance_m": min(swing) if swing else None,
            "max_penetration_m": max(s["penetration_m"] for s in self.samples),
            "reads": len(self.reads),
        }

    @cached_property
    def motion(self) -> SampledMotion:
        return SampledMotion("bioloid_stairs", self.robot, np.array(self.configurations),
                             np.array(self.phase_of), self.phase_names, self.support)


def _leading_foot(cycle: int) -> str:
    return "r" if WALK_CYCLE[cycle % 4].startswith("WalkSR") else "l"


def simulate_stairs(robot: Robot, stairs: Staircase | None = None, gait: GaitParameters | None = None,
                    margin: float = 0.005, climbs: int | None = None, q0: np.ndarray | None = None,
                    max_decisions: int = STEP_QTY, backend: str = DEFAULT_BACKEND,
                    com_inset: float = COM_INSET) -> StairRun:
    """Half steps toward the staircase, climbing (and with ``descend`` going down) as the state machine
    decides after each, until done or ``max_decisions`` reads; StairError when a foot would hit a riser.
    ``com_inset``: see :func:`stair_phases`."""
    stairs = stairs or Staircase()
    gait = gait or GaitParameters()
    climbs = stairs.steps if climbs is None else int(climbs)
    descents = stairs.steps if stairs.descend and climbs == stairs.steps else 0
    run = StairRun(robot, stairs, gait, margin, backend, climbs, start_q(robot, q0), com_inset)
    cycle = 0
    for _ in range(max_decisions):
        if run.climbed >= climbs and run.descended >= descents:
            break
        name = WALK_CYCLE[cycle % 4]
        cycle += 1
        run.half(name)
        read = run.read(name)
        decision = run.machine.after_placement(read["sharp_mm"], read["front_fsr_mv"], read["forward_foot"])
        if decision.action in ("down", "back_then_down"):
            back = "BackS" + decision.foot.upper()
            if run.descended >= descents:  # a step down the staircase does not have: not generated
                run.states.append(back if decision.action == "back_then_down" else "DownStair")
                break
            if decision.action == "back_then_down":
                run.half(back)
                cycle = 0 if decision.foot == "r" else 2  # the next half step starts with this foot
            heel = float(sole_points(robot, SOLE["r"], run.soles()["r"])[:, 0].min())
            level = stairs.step_at(heel + 1e-6)
            if run.stair_ready(cycle, down=True):
                cycle += 2
            phases, after = stair_phases(robot, run.soles(), stairs, level, _leading_foot(cycle), gait, True,
                                         com_inset)
            run.solve("DownStair", phases, after)
            run.descended += 1
            run.machine.descended()
            run.read("DownStair")
        elif decision.action == "up":
            if name in PAIR_END:  # ours: the feet side by side before the re-reads
                run.half(PAIR_END[name])
                cycle += 1
                run.read(PAIR_END[name])
            for _turn in range(MAX_TURNS):
                side = StairStateMachine.turn(run.read("re-read")["sharp_mm"])
                if side is None:
                    break
                angle = math.radians(TURN_MEDIUM_DEG) * (1 if side == "left" else -1)
                phases, after = turn_phases(robot, run.soles(), angle, gait)
                run.solve("RightTurnMedium" if side == "right" else "LeftTurnMedium", phases, after)
            run.stair_ready(cycle, down=False)
            step = run.climbed + 1
            phases, after = stair_phases(robot, run.soles(), stairs, step, _leading_foot(cycle), gait,
                                         com_inset=com_inset)
            run.solve("UpStair", phases, after)
            run.machine.climbed()
            run.read("UpStair")
    return run
