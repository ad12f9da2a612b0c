"""Whole-body tracking of a walk pattern, one QP step per tick."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.collision import CollisionModel
from wbik.errors import NoQPSolutionError, UnsupportedError
from wbik.models import robot_entries
from wbik.motion.walking.control_loop import without_cyclic_gc
from wbik.motion.walking.feedforward import SwingMomentum
from wbik.motion.walking.footsteps import Feet
from wbik.motion.walking.pattern import WalkPattern, walk_pattern
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.contacts import Contact
from wbik.qp.distances import CollisionAvoidance
from wbik.qp.limits import JointPositionLimits, JointVelocityLimits, LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.tasks import ComTask, FrameTask, OrientationTask, PostureTask, RegularizationTask
from wbik.robot import Robot


@dataclass(frozen=True)
class TrackingSettings:
    """Task weights, the trunk frame (None: the floating base's first body), joints held still, leg
    self-collision (``safety_distance`` m; ``leg_capsules`` for a robot without package primitives)."""

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
    """The tracked walk: ``q`` (K, nq) at the pattern's ticks, each tick's step time (s), ``failed`` ticks."""

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
    """``settings.trunk`` or the floating base's first body frame."""
    if settings.trunk is not None:
        robot.frame_id(settings.trunk)
        return settings.trunk
    for frame in robot.model.frames:
        if frame.parentJoint == 1 and frame.type == pin.FrameType.BODY:
            return frame.name
    raise UnsupportedError(f"{robot.name!r} has no body on its first joint; name the trunk frame")


def leg_collision_model(robot: Robot, feet: Feet, capsules: tuple = ()):
    """The collision model of the package's primitives and ``capsules``, left against right leg only."""
    entry = robot_entries().get(robot.name)
    listed = getattr(entry.module(), "collision_primitives", None) if entry is not None else None
    if listed is None and not capsules:
        return None
    shapes = [*(listed(robot) if listed is not None else ()), *capsules]
    full = CollisionModel(robot.model, shapes, reference=robot.nominal)
    model = robot.model
    legs = [set(model.supports[model.frames[model.getFrameId(frame)].parentJoint].tolist()[2:])
            for frame in feet.frames]  # the joints below the universe and the floating base
    parents = {obj.name: obj.parentJoint for obj in full.geometry.geometryObjects}
    pairs = [(a, b) for a, b in full.pairs
             if any(parents[a] in one and parents[b] in other for one, other in (legs, legs[::-1]))]
    return CollisionModel(robot.model, shapes, reference=robot.nominal, pairs=pairs)


class Foothold(Contact):
    """A contact whose world pose can be moved between steps (``placement``)."""

    def __init__(self, frame: str, placement: pin.SE3):
        super().__init__(frame, placement.copy())
        self.name = f"foothold[{frame}]"

    @Contact.placement.setter
    def placement(self, value: pin.SE3) -> None:
        self._task.target = self.fixed_placement = value.copy()
        self._version = -1  # the rows of the new pose


class _Stage:
    """The QP of one kind of support, built once; its targets move from tick to tick."""

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
        velocity = [JointVelocityLimits()] if settings.velocity_limits else []
        locked = [LockedJoints(list(settings.locked))] if settings.locked else []
        self.constraints = [JointPositionLimits(), *velocity, *locked]
        self.collision_model = (leg_collision_model(robot, feet, settings.leg_capsules)
                                if settings.self_collision else None)
        if self.collision_model is not None and self.collision_model.pairs:
            self.constraints.append(CollisionAvoidance(self.collision_model, settings.safety_distance,
                                                       influence_distance=settings.safety_distance + 0.03))
        self._stages: dict[tuple, _Stage] = {}
        for stance, swing in ((feet.frames, None), ((feet.right,), "left"), ((feet.left,), "right")):
            self.stage(stance, swing).problem.start(self.q0)  # built before the first tick, not during one

    def trunk_rotation(self, heading_change: float) -> np.ndarray:
        """The trunk's target: its standing pitch and roll, turned by ``heading_change`` (rad)."""
        return pin.utils.rotate("z", self._trunk_heading0 + heading_change) @ self._trunk_level

    def stage(self, stance: tuple[str, ...], swing: str | None) -> _Stage:
        key = (tuple(sorted(stance)), swing)
        return self._stages.get(key) or self._stages.setdefault(key, _Stage(self, key[0], swing, self.q0))

    def step(self, q: np.ndarray, pattern: WalkPattern, k: int, com_offset: np.ndarray | None = None,
             trunk_correction: np.ndarray | None = None) -> np.ndarray:
        """q_(k+1) from q_k toward the pattern's tick k + 1 (NoQPSolutionError when the QP has none); the CoM
        target moved by ``com_offset`` (m), the trunk's turned by ``trunk_correction`` (a rotation, world)."""
        stance, swing = pattern.stance(k), pattern.swing[k]
        stage = self.stage(tuple(stance), swing)
        for frame, placement in stance.items():
            foothold = stage.footholds[frame]
            if not np.array_equal(foothold.placement.homogeneous, placement.homogeneous):
                foothold.placement = placement
        stage.com.target[:] = pattern.com[k] if com_offset is None else pattern.com[k] + com_offset
        trunk = self.trunk_rotation(pattern.trunk_yaw[k] - pattern.trunk_yaw[0])
        stage.trunk.target = trunk if trunk_correction is None else trunk_correction @ trunk
        if swing is not None:
            stage.swing.target = pattern.feet_poses[swing][k]
        return pin.integrate(self.robot.model, q, stage.problem.step(q, dt=pattern.dt))


def track(robot: Robot, pattern: WalkPattern, q0: np.ndarray, settings: TrackingSettings | None = None,
          backend: str = DEFAULT_BACKEND) -> WalkMotion:
    """Every tick of ``pattern`` tracked from ``q0``; a tick without a QP solution keeps q (``failed``)."""
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
         settings: TrackingSettings | None = None, zmp_forward: float = 0.0, backend: str = DEFAULT_BACKEND,
         feedforward: bool = True) -> WalkMotion:
    """Plan a walk and track it; with ``feedforward`` the pendulum's reference starts from rest and carries
    the swing leg's angular momentum (:mod:`wbik.motion.walking.feedforward`), from the plan alone."""
    settings = settings or TrackingSettings()
    feet = feet or Feet.of(robot)
    trunk = trunk_frame(robot, settings)
    momentum = SwingMomentum(robot, q0, feet, trunk, settings.locked) if feedforward else None
    pattern = walk_pattern(robot, q0, steps, timing, dt=dt, clearance=clearance, feet=feet, preview=preview,
                           com_height=com_height, zmp_forward=zmp_forward, rest=feedforward,
                           momentum=momentum)
    motion = track(robot, pattern, q0, settings, backend)
    motion.info["feedforward"] = feedforward
    return motion
