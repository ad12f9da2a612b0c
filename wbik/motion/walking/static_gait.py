"""Quasi-static whole-body motion: phases of samples, each a converged whole-body IK from the previous
answer with the soles held, the CoM ``margin`` inside the support and the joint limits hard, verified by FK
(:func:`quasi_static_motion`); and on it the quasi-static gait on given footsteps (:func:`static_gait`):
CoM over the stance sole then swing, timed like servos at ``speed_rpm``."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError, NoQPSolutionError
from wbik.motion.timing import RPM, time_samples
from wbik.motion.walking.footsteps import OTHER, SIDES, Feet, Footstep, mean_yaw, placed_on, sole_polygon
from wbik.motion.walking.multibody_zmp import actuated_joints, limit_excess
from wbik.motion.walking.swing import swing_pose
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import Contact
from wbik.qp.limits import JointPositionLimits, LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.tasks import ComTask, OrientationTask, PostureTask, RegularizationTask
from wbik.robot import Robot

CONTACT_TOLERANCE = 1e-6  # m, rad: contacts and swing paths hold to this at every sample
REPAIR_INSET = 0.0005  # m, a sample ending with the CoM outside is repaired this far inside the margin

Path = Callable[[float], pin.SE3]
Point = Callable[[float], np.ndarray]


@dataclass
class BodyPhase:
    """One phase, sampled at s = 1/divisions, ..., 1: soles held at ``stance`` or on ``swing`` paths, soft
    targets of s (``hips``: frame -> position, the trunk's ``pelvis_rotation``, the ``com`` xy);
    ``end_support``: the soles holding the CoM at the last sample; ``clip_x``: sole -> x where ground ends."""

    name: str
    stance: dict[str, pin.SE3]
    swing: dict[str, Path] = field(default_factory=dict)
    hips: dict[str, Point] = field(default_factory=dict)
    pelvis_rotation: Callable[[float], np.ndarray] | None = None
    com: Point | None = None
    end_support: tuple[str, ...] | None = None
    divisions: int = 5
    clip_x: dict[str, float] = field(default_factory=dict)


def nearest_inside(polygon: SupportPolygon, point: np.ndarray, margin: float) -> np.ndarray:
    """Nearest point to ``point`` of the polygon shrunk by ``margin``; InvalidConfigurationError if empty."""
    try:
        return polygon.nearest_inside(point, margin)
    except NoQPSolutionError as error:
        raise InvalidConfigurationError(f"the support polygon shrunk by {margin} m is empty") from error


class ComRamp:
    """CoM target s -> start + s (goal - start), ``start`` bound to the CoM at the phase start; without a
    ``goal``, the nearest point of ``polygon`` (of the soles ``footprint``) shrunk by ``inset``; without
    either, the start (the CoM held)."""

    def __init__(self, polygon: SupportPolygon | None = None, inset: float = 0.0,
                 goal: np.ndarray | None = None, footprint: dict[str, pin.SE3] | None = None):
        self.polygon, self.footprint, self.inset = polygon, footprint, float(inset)
        self.goal = None if goal is None else np.asarray(goal, dtype=float)[:2]
        self.start: np.ndarray | None = None

    def bind(self, com_xy: np.ndarray) -> None:
        self.start = np.asarray(com_xy, dtype=float)[:2].copy()
        if self.goal is None:
            self.goal = self.start if self.polygon is None else nearest_inside(self.polygon, self.start,
                                                                               self.inset)

    def __call__(self, s: float) -> np.ndarray:
        if self.start is None or self.goal is None:
            raise InvalidConfigurationError("ComRamp used before the engine bound its start")
        return self.start + s * (self.goal - self.start)


def pose_error(reached: pin.SE3, wanted: pin.SE3) -> tuple[float, float]:
    """(position error in m, rotation angle in rad) of ``reached`` against ``wanted``."""
    return (float(np.linalg.norm(reached.translation - wanted.translation)),
            float(np.linalg.norm(pin.log3(wanted.rotation.T @ reached.rotation))))


def holds(check: dict) -> bool:
    """Whether a sample's FK check (:func:`verify_sample`) passed."""
    return check["contacts_ok"] and check["balance_ok"] and check["limits_ok"]


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


@dataclass
class SampledMotion:
    """Whole-body configurations ``q[k]`` at the samples (0: the start), the index of each one's phase in
    ``phase_names`` (-1: the start) and its soles on the ground."""

    name: str
    robot: object
    q: np.ndarray
    phase: np.ndarray
    phase_names: list[str]
    support: list[tuple[str, ...]]

    @property
    def joint_names(self) -> list[str]:
        return [self.robot.model.names[j] for j in actuated_joints(self.robot.model)]

    def joint_matrix(self) -> np.ndarray:
        """(K, n) joint angles (rad) in ``joint_names`` order (the floating base left out)."""
        model = self.robot.model
        return self.q[:, [model.joints[j].idx_q for j in actuated_joints(model)]]

    def phase_end_samples(self) -> list[int]:
        """Index of the last sample of every phase."""
        count = len(self.phase)
        return [k for k in range(1, count) if k + 1 == count or self.phase[k + 1] != self.phase[k]]


@dataclass
class WholeBodyMotion:
    """The solved samples with their FK checks (one dict per sample after the start)."""

    motion: SampledMotion
    checks: list[dict]
    margin: float
    phases: list[BodyPhase]

    @property
    def passed(self) -> bool:
        return all(holds(c) for c in self.checks)

    def summary(self) -> dict:
        return {
            "samples": len(self.checks), "passed": self.passed, "margin_mm": 1e3 * self.margin,
            "max_contact_error_m": max(c["contact_error_m"] for c in self.checks),
            "max_contact_error_rad": max(c["contact_error_rad"] for c in self.checks),
            "min_com_margin_mm": 1e3 * min(c["com_margin_m"] for c in self.checks),
            "max_limit_excess_rad": max(c["limit_excess_rad"] for c in self.checks),
            "max_hip_error_mm": 1e3 * max(c["hip_error_m"] for c in self.checks),
            "max_pelvis_orientation_error_deg": max(c["pelvis_error_deg"] for c in self.checks),
            "solve_time_s": sum(c["time_s"] for c in self.checks),
        }


def quasi_static_motion(robot: Robot, q0: np.ndarray, phases: Sequence[BodyPhase],
                        tasks: Callable[[BodyPhase, float, np.ndarray | None], list], margin: float = 0.005,
                        backend: str = DEFAULT_BACKEND, max_iterations: int = 60, retries: int = 3,
                        locked: Sequence[str] = (), name: str = "behaviour") -> WholeBodyMotion:
    """Every sample of every phase solved from the previous answer, ``tasks(phase, s, CoM xy target or
    None)`` soft and ``locked`` joints held, and verified by FK (a failed one repaired up to ``retries``
    times)."""
    if margin < 0:
        raise InvalidConfigurationError(f"the CoM margin must be >= 0, got {margin}")
    q = np.asarray(q0, dtype=float).copy()
    configurations, phase_of, support = [q.copy()], [-1], [tuple(phases[0].stance) if phases else ()]
    checks: list[dict] = []
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
                            *([LockedJoints(list(locked))] if locked else [])]
            problem = IKProblem(robot.model, tasks(phase, s, None if phase.com is None else phase.com(s)),
                                constraints, backend=backend, max_step=0.1, progress=1e-6)
            solution = problem.solve(q, max_iterations=max_iterations, diagnose=False)
            check = verify_sample(robot, solution.q, held, active, margin)
            for _ in range(retries):
                if holds(check):
                    break
                # the IK loop never raises its task cost, so pull the CoM inside alone first, then re-solve
                inside = nearest_inside(active, robot.center_of_mass(solution.q)[:2], margin + REPAIR_INSET)
                repair = IKProblem(robot.model, [ComTask(np.r_[inside, 0.0], axes="xy", tolerance=1e-7,
                                                         name="com repair"), RegularizationTask(1e-8)],
                                   constraints, backend=backend, max_step=0.1)
                repaired = repair.solve(solution.q, max_iterations=max_iterations, diagnose=False)
                solution = problem.solve(repaired.q, max_iterations=max_iterations, diagnose=False)
                check = verify_sample(robot, solution.q, held, active, margin)
            q = solution.q.copy()
            errors = solution.task_errors
            check.update({
                "phase": index, "division": division, "reason": solution.reason,
                "iterations": solution.iterations, "time_s": solution.time_s,
                "hip_error_m": max((errors[f"hip {f}"] for f in phase.hips), default=0.0),
                "pelvis_error_deg": math.degrees(errors.get("pelvis orientation", 0.0))})
            checks.append(check)
            configurations.append(q.copy())
            phase_of.append(index)
            support.append(tuple(sorted(phase.stance)))
    motion = SampledMotion(name, robot, np.array(configurations), np.array(phase_of),
                           [phase.name for phase in phases], support)
    return WholeBodyMotion(motion, checks, margin, list(phases))


@dataclass
class StaticGait:
    """Samples ``q`` (K, nq), soles down, the sole each stands on and where (``anchor``), CoM margin (m)."""

    robot: Robot
    q: np.ndarray
    support: list[tuple[str, ...]]
    anchor: list[tuple[str, pin.SE3]]
    timed: object  # wbik.motion.timing.TimedPath of the actuated joints
    com_margin_m: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(self.timed.duration)

    def resample(self, dt: float) -> tuple[np.ndarray, np.ndarray, list[tuple[str, ...]]]:
        """(times, configurations, support) every ``dt`` s, each sample's stance sole kept where it stands."""
        model = self.robot.model
        actuated = [model.joints[j].idx_q for j in actuated_joints(model)]
        times = np.arange(0.0, self.duration + 0.5 * dt, dt)
        joints, _, _ = self.timed.evaluate(times)
        knots = np.asarray(self.timed.knot_times, dtype=float)
        rows, support = [], []
        for t, values in zip(times, joints, strict=True):
            # the sample this stretch of the timing moves to
            segment = int(np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)) + 1
            q = self.q[segment].copy()
            q[actuated] = values
            rows.append(placed_on(self.robot, q, *self.anchor[segment]))
            support.append(self.support[segment])
        return times, np.array(rows), support


def static_gait(robot: Robot, q0: np.ndarray, footsteps: list[Footstep], feet: Feet, trunk: str,
                clearance: float = 0.02, margin: float = 0.005, inset: float | None = None,
                divisions: int = 5, speed_rpm: float = 40.0, locked: tuple[str, ...] = (),
                backend: str = DEFAULT_BACKEND) -> StaticGait:
    """The quasi-static gait through ``footsteps``; the CoM goes ``inset`` (m) inside the stance sole."""
    inset = max(0.008, margin + 0.003) if inset is None else float(inset)
    if divisions < 1 or not speed_rpm > 0:
        raise InvalidConfigurationError(f"divisions must be >= 1 and speed_rpm > 0, got {divisions}, "
                                        f"{speed_rpm}")
    if inset < margin:
        raise InvalidConfigurationError(f"the CoM goes {inset} m inside the stance sole, less than the "
                                        f"margin {margin} m")
    q = np.asarray(q0, dtype=float).copy()
    stand = {side: robot.frame_placement(q, feet.frame(side)) for side in SIDES}
    trunk_rotation = robot.frame_placement(q, trunk).rotation
    heading0 = math.atan2(trunk_rotation[1, 0], trunk_rotation[0, 0])
    level = pin.utils.rotate("z", -heading0) @ trunk_rotation
    com_height = float(robot.center_of_mass(q)[2])
    feet_heading0 = mean_yaw(stand["left"], stand["right"])
    phases, anchors = [], [(feet.left, stand["left"])]  # the sole each phase stands on (the start's first)

    def add(name: str, stance_side: str, held: dict[str, pin.SE3], **options) -> None:
        """A phase standing on the ``stance_side`` sole, the trunk level and turned with the feet."""
        heading = heading0 + mean_yaw(stand["left"], stand["right"]) - feet_heading0
        rotation = pin.utils.rotate("z", heading) @ level
        phases.append(BodyPhase(name, held, pelvis_rotation=lambda s: rotation, **options))
        anchors.append((feet.frame(stance_side), held[feet.frame(stance_side)]))

    def shift(side: str | None) -> None:
        """Double support: the CoM into the ``side`` sole (None: between the feet)."""
        both = {feet.frame(s): stand[s] for s in SIDES}
        if side is None:
            middle = 0.5 * (stand["left"].translation + stand["right"].translation)
            add("CoM between the feet", "left", both, com=ComRamp(goal=middle), divisions=divisions)
        else:
            single = {feet.frame(side): stand[side]}
            add(f"CoM over the {side} foot", side, both, com=ComRamp(sole_polygon(robot, single), inset),
                end_support=tuple(single), divisions=divisions)

    for step in footsteps:
        stance_side = OTHER[step.side]
        shift(stance_side)
        add(f"swing the {step.side} foot", stance_side, {feet.frame(stance_side): stand[stance_side]},
            swing={step.frame: partial(swing_pose, stand[step.side], step.placement, clearance=clearance)},
            com=ComRamp(), divisions=2 * divisions)
        stand[step.side] = step.placement
    shift(None)

    def tasks(phase: BodyPhase, s: float, com_xy: np.ndarray) -> list:
        return [ComTask(np.r_[com_xy, com_height], axes="xy", weight=10.0, tolerance=1e-7, name="com"),
                OrientationTask(trunk, phase.pelvis_rotation(s), weight=0.02, goal=False, name="trunk"),
                PostureTask(q0, weight=1e-4, priority=1), RegularizationTask(1e-8)]

    solved = quasi_static_motion(robot, q, phases, tasks, margin, backend, retries=0, locked=locked,
                                 name="static gait")
    motion, ends = solved.motion, solved.motion.phase_end_samples()
    timed = actuated_timing(robot.model, motion.q, speed_rpm, "segment", ends)
    return StaticGait(robot, motion.q, motion.support, [anchors[p + 1] for p in motion.phase], timed,
                      np.array([np.nan] + [c["com_margin_m"] for c in solved.checks]),
                      {"divisions": divisions, "speed_rpm": speed_rpm, "margin": margin, "inset": inset,
                       "mode": "segment", "phase_ends": ends})


def actuated_timing(model: pin.Model, configurations: np.ndarray, speed_rpm: float | None, mode: str,
                    phase_ends: list[int], law: str = "quintic"):
    """The shortest timing of the samples' 1-DOF joints at ``speed_rpm`` (None: the URDF's limits)."""
    joints = [model.joints[j] for j in actuated_joints(model)]
    limit = model.velocityLimit[[joint.idx_v for joint in joints]] if speed_rpm is None else speed_rpm * RPM
    return time_samples(configurations[:, [joint.idx_q for joint in joints]], limit, law, mode, phase_ends)


def retimed(gait: StaticGait, speed_rpm: float, mode: str = "segment") -> StaticGait:
    """The samples at ``speed_rpm``, at rest at every sample ("segment") or phase end ("waypoint")."""
    if not speed_rpm > 0:
        raise InvalidConfigurationError(f"speed_rpm must be > 0, got {speed_rpm}")
    if gait.info.get("mode") == mode:
        timed = scaled_timing(gait.timed, gait.info["speed_rpm"] / speed_rpm)
    else:
        timed = actuated_timing(gait.robot.model, gait.q, speed_rpm, mode, gait.info["phase_ends"])
    return replace(gait, timed=timed, info={**gait.info, "speed_rpm": speed_rpm, "mode": mode})


def scaled_timing(timed, factor: float):
    """A TimedPath (:mod:`wbik.motion.timing`, velocity limit only) run ``factor`` times slower."""
    pieces = [replace(piece, start=piece.start * factor, duration=piece.duration * factor)
              for piece in timed.pieces]
    return replace(timed, pieces=pieces, knot_times=np.asarray(timed.knot_times) * factor,
                   duration=timed.duration * factor, velocity_limit=np.asarray(timed.velocity_limit) / factor)
