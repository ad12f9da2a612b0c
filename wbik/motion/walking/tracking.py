"""Whole-body tracking of a walk pattern: one QP step of :mod:`wbik.qp` per control tick, from q_k toward
the pattern's tick k + 1 (q_(k+1) = q_k (+) dq).

Hard: the soles on the ground held at their footholds (:class:`Foothold`, 6 rows each), joint position
and velocity limits, self-collision between the legs, ``locked`` joints. Soft: the CoM on the pattern's,
the swinging sole on its trajectory, the trunk's standing pitch and roll turned to the feet's heading, a
posture term and a small regularisation. One QP per kind of support is built before the first tick.

The dynamics filter (:func:`walk`): with ``filter_iterations`` n > 0 the pattern is planned again with
its reference shifted by the measured error, p_ref' = p_ref + sum (p_ref - p_multibody), faded in over
the first double support (the robot starts at rest), and tracked again, n times.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from dataclasses import field

import numpy as np
import pinocchio as pin

from wbik.errors import NoQPSolutionError
from wbik.errors import UnsupportedError
from wbik.motion.walking.control_loop import without_cyclic_gc
from wbik.motion.walking.footsteps import SIDES
from wbik.motion.walking.footsteps import Feet
from wbik.motion.walking.multibody_zmp import multibody_zmp
from wbik.motion.walking.multibody_zmp import trajectory_derivatives
from wbik.motion.walking.pattern import SETTLE_MAX_S
from wbik.motion.walking.pattern import WalkPattern
from wbik.motion.walking.pattern import walk_pattern
from wbik.motion.walking.swing import quintic
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.constraint import EqualityConstraint
from wbik.qp.distances import CollisionAvoidance
from wbik.qp.limits import JointPositionLimits
from wbik.qp.limits import JointVelocityLimits
from wbik.qp.limits import LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.rows import EqualityRows
from wbik.qp.tasks import ComTask
from wbik.qp.tasks import FrameTask
from wbik.qp.tasks import OrientationTask
from wbik.qp.tasks import PostureTask
from wbik.qp.tasks import RegularizationTask
from wbik.robot import Robot


@dataclass(frozen=True)
class TrackingSettings:
    """Weights of the soft tasks, the trunk frame (None: the floating base's first body), joints held
    still, whether the legs avoid each other (``safety_distance`` m) and the legs' collision capsules
    (:class:`wbik.collision.Primitive`) for a robot whose package lists no collision primitives."""

    com_weight: float = 100.0
    foot_weight: float = 100.0
    trunk_weight: float = 1.0
    posture_weight: float = 1e-3
    regularization: float = 1e-6
    trunk: str | None = None
    locked: tuple[str, ...] = ()
    self_collision: bool = True
    safety_distance: float = 0.003
    velocity_limits: bool = True
    leg_capsules: tuple = ()


@dataclass
class WalkMotion:
    """The tracked walk: configurations ``q`` (K, nq) at the pattern's ticks, each tick's whole-body step
    time (s), the ticks whose QP had no solution (``failed``), and the pattern tracked."""

    pattern: WalkPattern
    q: np.ndarray
    step_time_s: np.ndarray
    failed: list[int] = field(default_factory=list)
    collision_pairs: int = 0
    info: dict = field(default_factory=dict)
    step_cpu_s: np.ndarray | None = None

    @property
    def tick_time_s(self) -> np.ndarray:
        """Pattern + whole-body step, per tick (s, wall clock)."""
        return self.pattern.tick_time_s + self.step_time_s

    @property
    def tick_cpu_s(self) -> np.ndarray:
        """Pattern + whole-body step, per tick (s, this thread's CPU time)."""
        return self.pattern.tick_cpu_s + self.step_cpu_s


def trunk_frame(robot: Robot, settings: TrackingSettings) -> str:
    """The frame whose orientation the trunk task holds: ``settings.trunk`` or the floating base's first
    body frame."""
    if settings.trunk is not None:
        robot.frame_id(settings.trunk)
        return settings.trunk
    for frame in robot.model.frames:
        if frame.parentJoint == 1 and frame.type == pin.FrameType.BODY:
            return frame.name
    raise UnsupportedError(f"{robot.name!r} has no body on its first joint; name the trunk frame")


def leg_collision_model(robot: Robot, feet: Feet, capsules: tuple = ()):
    """The collision model of the robot package's primitives and ``capsules``, restricted to pairs of a
    left-leg and a right-leg shape (the joints between the floating base and each foot); None without
    shapes."""
    from wbik.collision import CollisionModel
    from wbik.models import robot_entries

    entry = robot_entries().get(robot.name)
    listed = getattr(entry.module(), "collision_primitives", None) if entry is not None else None
    if listed is None and not capsules:
        return None
    shapes = [*(listed(robot) if listed is not None else ()), *capsules]
    full = CollisionModel(robot.model, shapes, reference=robot.nominal)
    model = robot.model
    legs = {}
    for side in SIDES:
        joint = model.frames[model.getFrameId(feet.frame(side))].parentJoint
        legs[side] = set(model.supports[joint].tolist()[2:])  # below the universe and the floating base
    parents = {obj.name: obj.parentJoint for obj in full.geometry.geometryObjects}
    pairs = [(a, b) for a, b in full.pairs
             if (parents[a] in legs["left"] and parents[b] in legs["right"])
             or (parents[a] in legs["right"] and parents[b] in legs["left"])]
    return CollisionModel(robot.model, shapes, reference=robot.nominal, pairs=pairs)


class Foothold(EqualityConstraint):
    """A sole held at a world pose that can be moved between steps (``placement``): J dq = -e,
    e = [p - p*; log3(R*^T R)]; ``violation`` the larger of the position (m) and rotation (rad) errors."""

    def __init__(self, frame: str, placement: pin.SE3):
        self.frame = frame
        self.name = f"foothold[{frame}]"
        self._task = FrameTask(frame, placement.copy(), name=self.name)
        self._jacobian, self._error = None, None

    @property
    def placement(self) -> pin.SE3:
        return self._task.target

    @placement.setter
    def placement(self, value: pin.SE3) -> None:
        self._task.target = value.copy()

    def start(self, kinematics) -> None:
        self._task.start(kinematics)
        self._jacobian, self._error = np.zeros((6, kinematics.nv)), np.zeros(6)

    def equality(self, kinematics) -> EqualityRows:
        self._task.fill(kinematics, self._jacobian, self._error)
        return EqualityRows(self._jacobian, -self._error)

    def violation(self, kinematics) -> float:
        error = self._task.error(kinematics)
        return float(max(np.linalg.norm(error[:3]), np.linalg.norm(error[3:])))


class _Stage:
    """The QP of one kind of support (the soles that stand, the side that swings), built once; its
    targets and footholds move from tick to tick."""

    def __init__(self, tracker: Tracker, stance: tuple[str, ...], swing: str | None, q0: np.ndarray):
        robot, settings = tracker.robot, tracker.settings
        self.com = ComTask(robot.center_of_mass(q0), weight=settings.com_weight, tolerance=1e-9, name="com")
        self.trunk = OrientationTask(tracker.trunk, tracker.trunk_rotation(0.0), weight=settings.trunk_weight,
                                     tolerance=1e-9, name="trunk")
        self.swing = None if swing is None else FrameTask(
            tracker.feet.frame(swing), robot.frame_placement(q0, tracker.feet.frame(swing)),
            weight=settings.foot_weight, tolerance=1e-9, name=f"swing {swing}")
        self.footholds = {frame: Foothold(frame, robot.frame_placement(q0, frame)) for frame in stance}
        tasks = [self.com, *([self.swing] if self.swing is not None else []), self.trunk,
                 PostureTask(np.asarray(q0, dtype=float), weight=settings.posture_weight),
                 RegularizationTask(settings.regularization)]
        self.problem = IKProblem(robot.model, tasks, [*self.footholds.values(), *tracker.constraints],
                                 backend=tracker.backend, max_step=0.5)


class Tracker:
    """The whole-body QP of a walk on one robot."""

    def __init__(self, robot: Robot, feet: Feet, q0: np.ndarray, settings: TrackingSettings | None = None,
                 backend: str = DEFAULT_BACKEND):
        self.robot, self.feet, self.backend = robot, feet, backend
        self.settings = settings = settings or TrackingSettings()
        self.trunk = trunk_frame(robot, settings)
        trunk = robot.frame_placement(q0, self.trunk).rotation
        self._trunk_heading0 = math.atan2(trunk[1, 0], trunk[0, 0])
        self._trunk_level = pin.utils.rotate("z", -self._trunk_heading0) @ trunk  # pitch and roll only
        self.q0 = np.asarray(q0, dtype=float).copy()
        self.constraints = [JointPositionLimits()]
        if settings.velocity_limits:
            self.constraints.append(JointVelocityLimits())
        if settings.locked:
            self.constraints.append(LockedJoints(list(settings.locked)))
        self.collision_model = (leg_collision_model(robot, feet, settings.leg_capsules)
                                if settings.self_collision else None)
        if self.collision_model is not None and self.collision_model.pairs:
            self.constraints.append(CollisionAvoidance(self.collision_model, settings.safety_distance,
                                                       influence_distance=settings.safety_distance + 0.03))
        self._stages: dict[tuple, _Stage] = {}
        kinds = (((feet.left, feet.right), None), ((feet.right,), "left"), ((feet.left,), "right"))
        for stance, swing in kinds:
            self.stage(stance, swing).problem.start(self.q0)  # built before the first tick, not during one

    def trunk_rotation(self, heading_change: float) -> np.ndarray:
        """The trunk's target: its standing pitch and roll, turned by ``heading_change`` (rad)."""
        return pin.utils.rotate("z", self._trunk_heading0 + heading_change) @ self._trunk_level

    def stage(self, stance: tuple[str, ...], swing: str | None) -> _Stage:
        key = (tuple(sorted(stance)), swing)
        if key not in self._stages:
            self._stages[key] = _Stage(self, key[0], swing, self.q0)
        return self._stages[key]

    def step(self, q: np.ndarray, pattern: WalkPattern, k: int) -> np.ndarray:
        """q_(k+1) from q_k toward the pattern's tick k + 1 (NoQPSolutionError when the QP has none)."""
        stance = pattern.stance(k)
        swing = pattern.swing[k]
        stage = self.stage(tuple(stance), swing)
        for frame, placement in stance.items():
            foothold = stage.footholds[frame]
            if not np.array_equal(foothold.placement.homogeneous, placement.homogeneous):
                foothold.placement = placement
        stage.com.target[:] = pattern.com[k]
        stage.trunk.target = self.trunk_rotation(pattern.trunk_yaw[k] - pattern.trunk_yaw[0])
        if swing is not None:
            stage.swing.target = pattern.feet_poses[swing][k]
        dq = stage.problem.step(q, dt=pattern.dt)
        return pin.integrate(self.robot.model, q, dq)


def track(robot: Robot, pattern: WalkPattern, q0: np.ndarray, settings: TrackingSettings | None = None,
          backend: str = DEFAULT_BACKEND) -> WalkMotion:
    """Every tick of ``pattern`` tracked from ``q0``; a tick whose QP has no solution keeps the
    configuration (listed in ``failed``)."""
    tracker = Tracker(robot, pattern.feet, q0, settings, backend)
    q = np.asarray(q0, dtype=float).copy()
    rows, times, cpu, failed = [q.copy()], np.zeros(pattern.ticks), np.zeros(pattern.ticks), []
    with without_cyclic_gc():  # a control loop: no collector pause inside a tick
        for k in range(1, pattern.ticks):
            tick, tick_cpu = time.perf_counter(), time.thread_time()
            try:
                q = tracker.step(q, pattern, k)
            except NoQPSolutionError:
                failed.append(k)
            times[k], cpu[k] = time.perf_counter() - tick, time.thread_time() - tick_cpu
            rows.append(q.copy())
    pairs = 0 if tracker.collision_model is None else len(tracker.collision_model.pairs)
    return WalkMotion(pattern, np.array(rows), times, failed, pairs, {"trunk": tracker.trunk}, cpu)


def walk(robot: Robot, q0: np.ndarray, steps, timing, dt: float = 0.01, clearance: float = 0.02,
         feet: Feet | None = None, preview=None, com_height: float | None = None,
         settings: TrackingSettings | None = None, filter_iterations: int = 1, zmp_forward: float = 0.0,
         backend: str = DEFAULT_BACKEND) -> WalkMotion:
    """Plan (:func:`~wbik.motion.walking.pattern.walk_pattern`) and track a walk, with
    ``filter_iterations`` passes of the dynamics filter."""

    options = {"dt": dt, "clearance": clearance, "feet": feet, "preview": preview, "com_height": com_height,
               "zmp_forward": zmp_forward}
    pattern = walk_pattern(robot, q0, steps, timing, **options)
    motion = track(robot, pattern, q0, settings, backend)
    longest = int(round((pattern.phases[-1].end + SETTLE_MAX_S) / dt)) + 1
    offset = np.zeros((longest, 2))
    window = np.array([quintic(k * dt / pattern.phases[0].end) for k in range(longest)])[:, None]
    for _ in range(int(filter_iterations)):
        velocity, acceleration = trajectory_derivatives(robot.model, motion.q, pattern.dt)
        measured = multibody_zmp(robot.model, motion.q, velocity, acceleration, pattern.ground_z)
        ticks = pattern.ticks
        offset[:ticks] += window[:ticks] * np.nan_to_num(pattern.zmp_reference - measured)
        offset[ticks:] = offset[ticks - 1]
        pattern = walk_pattern(robot, q0, pattern.footsteps, timing, zmp_offset=offset, **options)
        motion = track(robot, pattern, q0, settings, backend)
    motion.info["filter_iterations"] = int(filter_iterations)
    return motion
