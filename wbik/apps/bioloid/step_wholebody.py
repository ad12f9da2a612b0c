"""The thesis's step forward as whole-body IK, one QP solve per sample (:func:`solve_phases`, also behind
the turns, walks, half steps and stairs): contacts, CoM ``margin`` and joint limits hard and verified by FK;
hips, pelvis orientation, CoM ramp and posture soft."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import (
    HIP,
    OTHER,
    SIDE_NAME,
    SIDES,
    SOLE,
    GaitParameters,
    SampledMotion,
    pose_error,
    start_q,
    step_forward_phases,
)
from wbik.errors import InvalidConfigurationError, NoQPSolutionError
from wbik.geometry import wrap_to_pi
from wbik.motion.walking.footsteps import sole_polygon, yaw_of
from wbik.motion.walking.multibody_zmp import limit_excess
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import Contact
from wbik.qp.limits import JointPositionLimits, LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.tasks import ComTask, OrientationTask, PositionTask, PostureTask, RegularizationTask
from wbik.robot import Robot
from wbik.robot_packages.bioloid.model import ARM_JOINTS, BioloidFacts

CONTACT_TOLERANCE = 1e-6  # m, rad: contacts and swing paths hold to this at every sample
HIP_WEIGHT = 1.0
PELVIS_ORIENTATION_WEIGHT = 0.02
COM_WEIGHT = 10.0
POSTURE_WEIGHT = 1e-4
REPAIR_INSET = 0.0005  # m, a sample ending with the CoM outside is repaired this far inside the margin
RAMP_INSET = 0.008  # m, a hand-over moves the CoM this far inside the next stance sole

Path = Callable[[float], pin.SE3]
Point = Callable[[float], np.ndarray]


@dataclass
class BodyPhase:
    """One phase, sampled at s = 1/divisions, ..., 1: soles held at ``stance`` or on ``swing`` paths, soft
    targets of s; ``end_support``: the soles holding the CoM at the last sample; ``clip_x``: sole -> x where
    the ground under it ends."""

    name: str
    stance: dict[str, pin.SE3]
    swing: dict[str, Path] = field(default_factory=dict)
    hips: dict[str, Point] = field(default_factory=dict)
    pelvis_rotation: Callable[[float], np.ndarray] | None = None
    com: Point | None = None
    end_support: tuple[str, ...] | None = None
    divisions: int = 5
    clip_x: dict[str, float] = field(default_factory=dict)


def hip_target(robot: Robot, sole_placement: pin.SE3, key_point: np.ndarray) -> np.ndarray:
    """World position of a hip given its key point (hip relative to the ankle, in the foot's axes)."""
    height = robot.require_facts(BioloidFacts, "the Bioloid whole-body step").ankle_height
    ankle = sole_placement.translation + sole_placement.rotation @ np.array([0.0, 0.0, height])
    return ankle + sole_placement.rotation @ key_point


def pelvis_rotation(yaw: float, pitch: float) -> np.ndarray:
    """Pelvis orientation: yaw about the world z, then the torso pitch about the turned y axis."""
    return pin.utils.rotate("z", yaw) @ pin.utils.rotate("y", pitch)


def line(start: np.ndarray, end: np.ndarray) -> Point:
    start, end = np.asarray(start, float), np.asarray(end, float)
    return lambda s: start + (end - start) * s


def sole_path(start: pin.SE3, end: pin.SE3, lift: float = 0.0) -> Path:
    """Flat swing path: a line plus ``lift * sin(pi s)`` up, the yaw turning linearly the short way."""
    def pose(s: float) -> pin.SE3:
        yaw = yaw_of(start.rotation) + s * float(wrap_to_pi(yaw_of(end.rotation) - yaw_of(start.rotation)))
        position = start.translation + s * (end.translation - start.translation)
        bump = np.array([0.0, 0.0, lift * math.sin(math.pi * s)])
        return pin.SE3(pin.utils.rotate("z", yaw), position + bump)

    return pose


def _holds(check: dict) -> bool:
    return check["contacts_ok"] and check["balance_ok"] and check["limits_ok"]


@dataclass
class WholeBodyMotion:
    """The solved samples with their FK checks (one dict per sample after the start)."""

    motion: SampledMotion
    checks: list[dict]
    margin: float
    phases: list[BodyPhase]

    @property
    def passed(self) -> bool:
        return all(_holds(c) for c in self.checks)

    def summary(self) -> dict:
        checks = self.checks
        return {
            "samples": len(checks), "passed": self.passed, "margin_mm": 1e3 * self.margin,
            "max_contact_error_m": max(c["contact_error_m"] for c in checks),
            "max_contact_error_rad": max(c["contact_error_rad"] for c in checks),
            "min_com_margin_mm": 1e3 * min(c["com_margin_m"] for c in checks),
            "max_limit_excess_rad": max(c["limit_excess_rad"] for c in checks),
            "max_hip_error_mm": 1e3 * max(c["hip_error_m"] for c in checks),
            "max_pelvis_orientation_error_deg": max(c["pelvis_error_deg"] for c in checks),
            "solve_time_s": sum(c["time_s"] for c in checks),
        }


def verify_sample(robot: Robot, q: np.ndarray, held: dict[str, pin.SE3], polygon: SupportPolygon,
                  margin: float) -> dict:
    """Independent FK check of one sample: held soles, CoM margin, joint limits."""
    position_error, rotation_error = 0.0, 0.0
    for sole, wanted in held.items():
        position, angle = pose_error(robot.frame_placement(q, sole), wanted)
        position_error, rotation_error = max(position_error, position), max(rotation_error, angle)
    com_margin = polygon.margin_of(robot.center_of_mass(q)[:2])
    excess = limit_excess(robot.model, q)
    return {"contact_error_m": position_error, "contact_error_rad": rotation_error,
            "contacts_ok": position_error <= CONTACT_TOLERANCE and rotation_error <= CONTACT_TOLERANCE,
            "com_margin_m": com_margin, "balance_ok": com_margin >= margin - 1e-9,
            "limit_excess_rad": excess, "limits_ok": excess <= 1e-9}


def solve_phases(robot: Robot, q0: np.ndarray, phases: Sequence[BodyPhase], margin: float = 0.005,
                 backend: str = DEFAULT_BACKEND, name: str = "behaviour", max_iterations: int = 60,
                 retries: int = 3) -> WholeBodyMotion:
    """Solve every sample of every phase from the previous sample's answer and verify it by FK."""
    if margin < 0:
        raise InvalidConfigurationError(f"the CoM margin must be >= 0, got {margin}")
    q = np.asarray(q0, dtype=float).copy()
    configurations, phase_of, support = [q.copy()], [-1], [tuple(phases[0].stance) if phases else ()]
    checks: list[dict] = []
    locked = [f"{side}_{name}" for side in SIDES for name in ARM_JOINTS]
    for index, phase in enumerate(phases):
        if isinstance(phase.com, ComRamp) and phase.com.start is None:
            if phase.com.footprint is not None and phase.clip_x:
                phase.com.polygon = sole_polygon(robot, phase.com.footprint, phase.clip_x)
            phase.com.bind(robot.center_of_mass(q)[:2])
        polygon = sole_polygon(robot, phase.stance, phase.clip_x)
        end_polygon = polygon if phase.end_support is None else sole_polygon(
            robot, {sole: phase.stance[sole] for sole in phase.end_support}, phase.clip_x)
        for division in range(1, phase.divisions + 1):
            s = division / phase.divisions
            active = end_polygon if division == phase.divisions else polygon
            held = {**phase.stance, **{sole: path(s) for sole, path in phase.swing.items()}}
            constraints = [Contact(sole, placement) for sole, placement in held.items()]
            constraints += [CoMInSupportPolygon(active, margin), JointPositionLimits(),
                            LockedJoints(locked)]
            tasks = [PositionTask(frame, target(s), weight=HIP_WEIGHT, tolerance=1e-12, name=f"hip {frame}")
                     for frame, target in phase.hips.items()]
            if phase.pelvis_rotation is not None:
                tasks.append(OrientationTask("pelvis", phase.pelvis_rotation(s),
                                             weight=PELVIS_ORIENTATION_WEIGHT,
                                             tolerance=1e-12, name="pelvis orientation"))
            if phase.com is not None:
                target = np.r_[phase.com(s), 0.0]
                tasks.append(ComTask(target, axes="xy", weight=COM_WEIGHT, tolerance=1e-12, name="com"))
            tasks += [PostureTask(robot.nominal, weight=POSTURE_WEIGHT), RegularizationTask(1e-8)]
            problem = IKProblem(robot.model, tasks, constraints, backend=backend, max_step=0.1, progress=1e-6)
            solution = problem.solve(q, max_iterations=max_iterations)
            check = verify_sample(robot, solution.q, held, active, margin)
            for _ in range(retries):
                if _holds(check):
                    break
                # the IK loop never raises its task cost, so pull the CoM inside alone first, then re-solve
                inside = nearest_inside(active, robot.center_of_mass(solution.q)[:2], margin + REPAIR_INSET)
                repair = IKProblem(robot.model, [ComTask(np.r_[inside, 0.0], axes="xy", tolerance=1e-7,
                                                         name="com repair"), RegularizationTask(1e-8)],
                                   constraints, backend=backend, max_step=0.1)
                repaired = repair.solve(solution.q, max_iterations=max_iterations)
                solution = problem.solve(repaired.q, max_iterations=max_iterations)
                check = verify_sample(robot, solution.q, held, active, margin)
            q = solution.q.copy()
            errors = solution.task_errors
            check.update({
                "phase": index, "division": division, "qp_feasible": solution.feasible,
                "reason": solution.reason, "iterations": solution.iterations, "time_s": solution.time_s,
                "hip_error_m": max((errors[f"hip {f}"] for f in phase.hips), default=0.0),
                "pelvis_error_deg": math.degrees(errors.get("pelvis orientation", 0.0)),
                "support": sorted(phase.stance)})
            checks.append(check)
            configurations.append(q.copy())
            phase_of.append(index)
            support.append(tuple(sorted(phase.stance)))
    motion = SampledMotion(name, robot, np.array(configurations), np.array(phase_of),
                           [p.name for p in phases], support)
    return WholeBodyMotion(motion, checks, margin, list(phases))


def current_soles(robot: Robot, q: np.ndarray) -> dict[str, pin.SE3]:
    return {side: robot.frame_placement(q, SOLE[side]) for side in SIDES}


def recentre_goal(robot: Robot, soles: dict[str, pin.SE3]) -> np.ndarray:
    """The CoM xy between the feet where the nominal stance has it, turned with the feet."""
    nominal = current_soles(robot, robot.nominal)
    offset = robot.center_of_mass(robot.nominal)[:2] - 0.5 * (nominal["r"].translation
                                                             + nominal["l"].translation)[:2]
    heading = 0.5 * (yaw_of(soles["r"].rotation) + yaw_of(soles["l"].rotation))
    middle = 0.5 * (soles["r"].translation + soles["l"].translation)[:2]
    return middle + pin.utils.rotate("z", heading)[:2, :2] @ offset


def step_phases(robot: Robot, soles: dict[str, pin.SE3], gait: GaitParameters | None = None,
                first: str = "left", rear_lift: float = 0.0) -> tuple[list[BodyPhase], dict[str, pin.SE3]]:
    """The 5 phases of one step forward, ``first`` foot first, the standing hips on the faithful step's
    key-point lines (:func:`step_forward_phases`); the phases and the soles planted after it."""
    gait = gait or GaitParameters()
    swing_side = "l" if str(first).lower() in ("left", "l") else "r"
    stance_side = OTHER[swing_side]
    table = step_forward_phases(gait, SIDE_NAME[swing_side])
    stance0, swing0 = soles[stance_side], soles[swing_side]
    heading = yaw_of(stance0.rotation)
    rotation = lambda s: pelvis_rotation(heading, gait.pitch)  # noqa: E731
    forward = stance0.rotation[:, 0]
    up = pin.SE3(swing0.rotation,
                 swing0.translation + forward * (gait.xm - gait.xu) + np.array([0, 0, gait.lift_height]))
    # land |xf| ahead of the stance foot, keeping the feet's lateral spacing
    ahead = float(forward @ (stance0.translation - swing0.translation)) + (gait.xm - gait.xf)
    landed = pin.SE3(swing0.rotation, swing0.translation + forward * ahead)
    beside = float(forward @ (landed.translation - stance0.translation))
    rear_end = pin.SE3(stance0.rotation, stance0.translation + forward * beside)
    before, after = {stance_side: stance0, swing_side: swing0}, {stance_side: stance0, swing_side: landed}

    def options(index: int, planted: dict[str, pin.SE3]) -> dict:
        phase = table[index]
        hips = {HIP[side]: line(hip_target(robot, planted[side], phase.start[side]),
                                hip_target(robot, planted[side], phase.end[side]))
                for side in phase.down if side != phase.dragged}
        return {"hips": hips, "pelvis_rotation": rotation, "divisions": gait.divisions}

    sw, st = SIDE_NAME[swing_side], SIDE_NAME[stance_side]
    return [
        com_over_phase(robot, f"shift the hips over the {st} foot", {SOLE[s]: p for s, p in before.items()},
                       stance_side, stance0, **options(0, before)),
        BodyPhase(f"lift the {sw} foot", {SOLE[stance_side]: stance0},
                  swing={SOLE[swing_side]: sole_path(swing0, up)}, **options(1, before)),
        BodyPhase(f"lower the {sw} foot ahead", {SOLE[stance_side]: stance0},
                  swing={SOLE[swing_side]: sole_path(up, landed)}, **options(2, before)),
        com_over_phase(robot, f"move the hips over the front ({sw}) foot",
                       {SOLE[s]: p for s, p in after.items()}, swing_side, landed, **options(3, after)),
        BodyPhase(f"bring the rear ({st}) foot beside the front one", {SOLE[swing_side]: landed},
                  swing={SOLE[stance_side]: sole_path(stance0, rear_end, lift=rear_lift)},
                  **options(4, after)),
    ], {stance_side: rear_end, swing_side: landed}


def nearest_inside(polygon: SupportPolygon, point: np.ndarray, margin: float) -> np.ndarray:
    """Nearest point to ``point`` of the polygon shrunk by ``margin``; InvalidConfigurationError if empty."""
    try:
        return polygon.nearest_inside(point, margin)
    except NoQPSolutionError as error:
        raise InvalidConfigurationError(f"the support polygon shrunk by {margin} m is empty") from error


class ComRamp:
    """CoM target s -> start + s (goal - start), ``start`` bound to the CoM at the phase start; without a
    ``goal``, the nearest point of ``polygon`` (of the soles ``footprint``) shrunk by ``inset``."""

    def __init__(self, polygon: SupportPolygon | None = None, inset: float = 0.0,
                 goal: np.ndarray | None = None, footprint: dict[str, pin.SE3] | None = None):
        self.polygon, self.footprint, self.inset = polygon, footprint, float(inset)
        self.goal = None if goal is None else np.asarray(goal, dtype=float)[:2]
        self.start: np.ndarray | None = None

    def bind(self, com_xy: np.ndarray) -> None:
        self.start = np.asarray(com_xy, dtype=float)[:2].copy()
        if self.goal is None:
            self.goal = nearest_inside(self.polygon, self.start, self.inset)

    def __call__(self, s: float) -> np.ndarray:
        if self.start is None or self.goal is None:
            raise InvalidConfigurationError("ComRamp used before the engine bound its start")
        return self.start + s * (self.goal - self.start)


def com_over_phase(robot: Robot, name: str, stance: dict[str, pin.SE3], side: str, placement: pin.SE3,
                   inset: float = RAMP_INSET, **options) -> BodyPhase:
    """A phase ramping the CoM ``inset`` into the ``side`` sole, ending on it alone."""
    footprint = {SOLE[side]: placement}
    return BodyPhase(name, stance, com=ComRamp(sole_polygon(robot, footprint), inset, footprint=footprint),
                     end_support=(SOLE[side],), **options)


def step_forward_wholebody(robot: Robot, gait: GaitParameters | None = None, first: str = "left",
                           margin: float = 0.005, q0: np.ndarray | None = None, rear_lift: float = 0.0,
                           backend: str = DEFAULT_BACKEND) -> WholeBodyMotion:
    """One step forward (``first`` foot lifted first) solved sample by sample by the QP layer."""
    q = start_q(robot, q0)
    phases, _ = step_phases(robot, current_soles(robot, q), gait, first, rear_lift)
    return solve_phases(robot, q, phases, margin, backend, name=f"step_forward_{first}_wholebody")
