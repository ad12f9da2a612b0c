"""The thesis's step forward as whole-body IK, one QP solve per sample (:func:`solve_phases`, also behind
the turns, walks, half steps and stairs): contacts, CoM ``margin`` and joint limits hard and verified by FK;
hips, pelvis orientation, CoM ramp and posture soft."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.gait import (
    HIP,
    OTHER,
    SIDE_NAME,
    SIDES,
    SOLE,
    GaitParameters,
    start_q,
    step_forward_phases,
)
from wbik.geometry import wrap_to_pi
from wbik.motion.walking.footsteps import sole_polygon, yaw_of
from wbik.motion.walking.static_gait import (
    BodyPhase,
    ComRamp,
    Path,
    Point,
    WholeBodyMotion,
    quasi_static_motion,
)
from wbik.qp.backends import DEFAULT as DEFAULT_BACKEND
from wbik.qp.tasks import ComTask, OrientationTask, PositionTask, PostureTask, RegularizationTask
from wbik.robot import Robot
from wbik.robot_packages.bioloid.model import ARM_JOINTS, BioloidFacts

HIP_WEIGHT = 1.0
PELVIS_ORIENTATION_WEIGHT = 0.02
COM_WEIGHT = 10.0
POSTURE_WEIGHT = 1e-4
RAMP_INSET = 0.008  # m, a hand-over moves the CoM this far inside the next stance sole


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


def solve_phases(robot: Robot, q0: np.ndarray, phases: Sequence[BodyPhase], margin: float = 0.005,
                 backend: str = DEFAULT_BACKEND, name: str = "behaviour", max_iterations: int = 60,
                 retries: int = 3) -> WholeBodyMotion:
    """The phases by :func:`~wbik.motion.walking.static_gait.quasi_static_motion`, the arms held; the hips,
    pelvis orientation, CoM ramp and nominal posture soft."""

    def tasks(phase: BodyPhase, s: float, com_xy: np.ndarray | None) -> list:
        chosen = [PositionTask(frame, target(s), weight=HIP_WEIGHT, tolerance=1e-12, name=f"hip {frame}")
                  for frame, target in phase.hips.items()]
        if phase.pelvis_rotation is not None:
            chosen.append(OrientationTask("pelvis", phase.pelvis_rotation(s),
                                          weight=PELVIS_ORIENTATION_WEIGHT, tolerance=1e-12,
                                          name="pelvis orientation"))
        if com_xy is not None:
            chosen.append(ComTask(np.r_[com_xy, 0.0], axes="xy", weight=COM_WEIGHT, tolerance=1e-12,
                                  name="com"))
        return [*chosen, PostureTask(robot.nominal, weight=POSTURE_WEIGHT), RegularizationTask(1e-8)]

    locked = [f"{side}_{joint}" for side in SIDES for joint in ARM_JOINTS]
    return quasi_static_motion(robot, q0, phases, tasks, margin, backend, max_iterations, retries, locked,
                               name)


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
