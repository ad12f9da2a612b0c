"""A robot's look: its URDF visuals, or sticks from its kinematics (cylinders between frames, joint balls)."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidSettingError
from wbik.robot import Robot

STICK_COLOR = np.array([0.91, 0.45, 0.10, 1.0])  # orange, RGBA in [0, 1]
JOINT_COLOR = np.array([0.20, 0.25, 0.35, 1.0])
STICK_RADIUS_RATIO = 0.02
MINIMUM_SEGMENT = 1e-6


def robot_extent(robot: Robot, q: np.ndarray | None = None) -> float:
    """Largest distance (m) from the root to any frame origin at q (nominal by default), at least 1 mm."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.nominal if q is None else q)
    origin = data.oMi[1].translation if robot.has_floating_base else np.zeros(3)
    distances = [np.linalg.norm(placement.translation - origin) for placement in data.oMf]
    return max(max(distances, default=0.0), 1e-3)


def visual_model(robot: Robot, style: str = "auto") -> tuple[pin.GeometryModel, str]:
    """The geometry to draw and its style, ``"visual"`` (URDF) or ``"stick"`` (``"auto"``: visual if any)."""
    if style not in ("auto", "visual", "stick"):
        raise InvalidSettingError(f"style must be 'auto', 'visual' or 'stick', got {style!r}")
    if style in ("auto", "visual"):
        geometry = urdf_visuals(robot)
        if geometry is not None and geometry.ngeoms > 0:
            return geometry, "visual"
        if style == "visual":
            warnings.warn(f"{robot.name} has no loadable visual geometry; drawing sticks", stacklevel=2)
    return stick_model(robot), "stick"


def urdf_visuals(robot: Robot) -> pin.GeometryModel | None:
    """The URDF's visual geometry, or None when it has none or its meshes cannot be found."""
    if "<visual" not in robot.urdf_text:
        return None
    try:
        return pin.buildGeomFromUrdfString(robot.model, robot.urdf_text, pin.GeometryType.VISUAL,
                                           package_dirs=list(robot.package_dirs))
    except (RuntimeError, ValueError) as exc:
        warnings.warn(f"{robot.name}: visual meshes did not load ({exc}); drawing sticks instead",
                      stacklevel=3)
        return None


def stick_segments(robot: Robot) -> list[tuple[str, int, np.ndarray, np.ndarray]]:
    """(name, parent joint id, start, end) of every stick, the points in the parent joint's frame."""
    model = robot.model
    segments = []
    for joint_id in range(1, model.njoints):
        parent = model.parents[joint_id]
        end = model.jointPlacements[joint_id].translation
        if np.linalg.norm(end) > MINIMUM_SEGMENT:
            segments.append((f"link_{model.names[joint_id]}", parent, np.zeros(3), end.copy()))
    for frame in model.frames:
        if frame.type not in (pin.FrameType.FIXED_JOINT, pin.FrameType.OP_FRAME):
            continue
        parent_frame = model.frames[frame.parentFrame]
        start = (parent_frame.placement.translation if parent_frame.parentJoint == frame.parentJoint
                 else np.zeros(3))
        end = frame.placement.translation
        if np.linalg.norm(end - start) > MINIMUM_SEGMENT:
            segments.append((f"link_{frame.name}", frame.parentJoint, start.copy(), end.copy()))
    return segments


def stick_model(robot: Robot, color: np.ndarray = STICK_COLOR) -> pin.GeometryModel:
    """Cylinders between joint frames and spheres at the joints (coal primitives)."""
    import coal

    radius = STICK_RADIUS_RATIO * robot_extent(robot)
    geometry = pin.GeometryModel()
    for name, joint_id, start, end in stick_segments(robot):
        length = float(np.linalg.norm(end - start))
        z_to_stick = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), (end - start) / length)
        placement = pin.SE3(z_to_stick.toRotationMatrix(), 0.5 * (start + end))
        shape = pin.GeometryObject(name, joint_id, placement, coal.Cylinder(radius, length))
        shape.meshColor = np.asarray(color, dtype=float)
        geometry.addGeometryObject(shape)
    for joint_id in range(2 if robot.has_floating_base else 1, robot.model.njoints):  # (not the free flyer)
        sphere = pin.GeometryObject(f"joint_{robot.model.names[joint_id]}", joint_id, pin.SE3.Identity(),
                                    coal.Sphere(1.6 * radius))
        sphere.meshColor = JOINT_COLOR.copy()
        geometry.addGeometryObject(sphere)
    return geometry
