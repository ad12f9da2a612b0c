"""The quasi-static gait on given footsteps: CoM over the stance sole then swing, every sample a
converged whole-body IK with the CoM ``margin`` inside the support, timed like servos at ``speed_rpm``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.motion.timing import RPM, time_samples
from wbik.motion.walking.footsteps import OTHER, SIDES, Feet, Footstep, mean_yaw, placed_on, sole_polygon
from wbik.motion.walking.multibody_zmp import actuated_joints
from wbik.motion.walking.swing import swing_pose
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.balance import CoMInSupportPolygon
from wbik.qp.contacts import Contact
from wbik.qp.limits import JointPositionLimits, LockedJoints
from wbik.qp.problem import IKProblem
from wbik.qp.support_polygon import SupportPolygon
from wbik.qp.tasks import ComTask, OrientationTask, PostureTask, RegularizationTask
from wbik.robot import Robot


@dataclass
class StaticGait:
    """Samples ``q`` (K, nq), soles down, the sole each stands on (``anchor``) and where, CoM margin (m)."""

    robot: Robot
    q: np.ndarray
    support: list[tuple[str, ...]]
    anchor: list[str]
    anchor_placement: list[pin.SE3]
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
            rows.append(placed_on(self.robot, q, self.anchor[segment], self.anchor_placement[segment]))
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
    model = robot.model
    q = np.asarray(q0, dtype=float).copy()
    stand = {side: robot.frame_placement(q, feet.frame(side)) for side in SIDES}
    trunk_rotation = robot.frame_placement(q, trunk).rotation
    heading0 = math.atan2(trunk_rotation[1, 0], trunk_rotation[0, 0])
    level = pin.utils.rotate("z", -heading0) @ trunk_rotation
    com_height = float(robot.center_of_mass(q)[2])
    rows, support, anchor, anchor_placement, margins = [q.copy()], [tuple(feet.frames)], [feet.left], \
        [stand["left"]], [np.nan]
    phase_ends: list[int] = []
    common = [JointPositionLimits()] + ([LockedJoints(list(locked))] if locked else [])
    feet_heading0 = mean_yaw(stand["left"], stand["right"])

    def sample(held: dict[str, pin.SE3], polygon: SupportPolygon, com_xy: np.ndarray, on_ground: tuple,
               stance_frame: str) -> None:
        nonlocal q
        heading = heading0 + mean_yaw(stand["left"], stand["right"]) - feet_heading0
        rotation = pin.utils.rotate("z", heading) @ level
        tasks = [ComTask(np.r_[com_xy, com_height], axes="xy", weight=10.0, tolerance=1e-7, name="com"),
                 OrientationTask(trunk, rotation, weight=0.02, goal=False, name="trunk"),
                 PostureTask(q0, weight=1e-4, priority=1), RegularizationTask(1e-8)]
        constraints = [*(Contact(f, p) for f, p in held.items()), CoMInSupportPolygon(polygon, margin)]
        problem = IKProblem(model, tasks, constraints + common, backend=backend, max_step=0.1)
        q = problem.solve(q, max_iterations=60).q.copy()
        rows.append(q.copy())
        support.append(on_ground)
        anchor.append(stance_frame)
        anchor_placement.append(held[stance_frame])
        margins.append(polygon.margin_of(robot.center_of_mass(q)[:2]))

    def shift(target_side: str | None) -> None:
        """Double support: the CoM into the ``target_side`` sole (None: between the feet)."""
        both = {feet.frame(s): stand[s] for s in SIDES}
        polygon = sole_polygon(robot, both)
        start = robot.center_of_mass(q)[:2]
        if target_side is None:
            goal = 0.5 * (stand["left"].translation + stand["right"].translation)[:2]
            end_polygon = polygon
        else:
            end_polygon = sole_polygon(robot, {feet.frame(target_side): stand[target_side]})
            goal = end_polygon.nearest_inside(start, inset)
        stance_frame = feet.frame(target_side or "left")
        for division in range(1, divisions + 1):
            s = division / divisions
            sample(both, end_polygon if division == divisions else polygon, start + s * (goal - start),
                   tuple(feet.frames), stance_frame)
        phase_ends.append(len(rows) - 1)

    for step in footsteps:
        stance_side = OTHER[step.side]
        shift(stance_side)
        stance_frame = feet.frame(stance_side)
        polygon = sole_polygon(robot, {stance_frame: stand[stance_side]})
        com_xy = robot.center_of_mass(q)[:2]
        for division in range(1, 2 * divisions + 1):
            pose = swing_pose(stand[step.side], step.placement, division / (2 * divisions), clearance)
            sample({stance_frame: stand[stance_side], step.frame: pose}, polygon, com_xy, (stance_frame,),
                   stance_frame)
        phase_ends.append(len(rows) - 1)
        stand[step.side] = step.placement
    shift(None)
    configurations = np.array(rows)
    timed = _timed(model, configurations, speed_rpm, "segment", phase_ends)
    return StaticGait(robot, configurations, support, anchor, anchor_placement, timed, np.array(margins),
                      {"divisions": divisions, "speed_rpm": speed_rpm, "margin": margin, "inset": inset,
                       "mode": "segment", "phase_ends": phase_ends})


def _timed(model: pin.Model, configurations: np.ndarray, speed_rpm: float, mode: str, phase_ends: list[int]):
    """The shortest quintic timing of the samples' 1-DOF joints at ``speed_rpm``."""
    joints = configurations[:, [model.joints[j].idx_q for j in actuated_joints(model)]]
    return time_samples(joints, speed_rpm * RPM, "quintic", mode, phase_ends)


def retimed(gait: StaticGait, speed_rpm: float, mode: str = "segment") -> StaticGait:
    """The samples at ``speed_rpm``, at rest at every sample ("segment") or phase end ("waypoint")."""
    if not speed_rpm > 0:
        raise InvalidConfigurationError(f"speed_rpm must be > 0, got {speed_rpm}")
    if gait.info.get("mode") == mode:
        timed = scaled_timing(gait.timed, gait.info["speed_rpm"] / speed_rpm)
    else:
        timed = _timed(gait.robot.model, gait.q, speed_rpm, mode, gait.info["phase_ends"])
    return replace(gait, timed=timed, info={**gait.info, "speed_rpm": speed_rpm, "mode": mode})


def scaled_timing(timed, factor: float):
    """A TimedPath (:mod:`wbik.motion.timing`, velocity limit only) run ``factor`` times slower."""
    pieces = [replace(piece, start=piece.start * factor, duration=piece.duration * factor)
              for piece in timed.pieces]
    return replace(timed, pieces=pieces, knot_times=np.asarray(timed.knot_times) * factor,
                   duration=timed.duration * factor, velocity_limit=np.asarray(timed.velocity_limit) / factor)
