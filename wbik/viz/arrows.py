"""An arrow in meshcat: a shaft and a cone along the local +y axis, the tip at the origin; its pose turns +y
onto a direction, the tip on a point (a push drawn ending on the pushed frame)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

HEAD_RATIO = 0.3  # the cone's share of the arrow's length
SHAFT_RADIUS_RATIO = 0.06  # of the arrow's length
HEAD_RADIUS_RATIO = 0.15


def arrow_parts(length: float) -> list[tuple[str, object, np.ndarray]]:
    """(name, meshcat geometry, 4 x 4 pose in the arrow's frame) of the shaft and the head."""
    import meshcat.geometry as mg

    head = HEAD_RATIO * length
    shaft = mg.Cylinder(length - head, SHAFT_RADIUS_RATIO * length)
    cone = mg.Cylinder(head, radiusTop=0.0, radiusBottom=HEAD_RADIUS_RATIO * length)
    return [("shaft", shaft, pin.SE3(np.eye(3), np.array([0.0, -(length + head) / 2, 0.0])).homogeneous),
            ("head", cone, pin.SE3(np.eye(3), np.array([0.0, -head / 2, 0.0])).homogeneous)]


def arrow_pose(point: np.ndarray, direction: np.ndarray, gap: float = 0.0) -> np.ndarray:
    """4 x 4 pose of an arrow pointing along ``direction`` (world) at ``point`` (world, m), its tip ``gap``
    (m) short of it."""
    unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), unit).toRotationMatrix()
    return pin.SE3(rotation, np.asarray(point, dtype=float) - gap * unit).homogeneous
