"""PhantomX Pincher binding (pincher.md's inverse): the yaw + planar 2R + wrist pitch member of the
yaw-planar family (:mod:`wbik.solvers.analytic.yaw_planar`) with the Pincher's geometry (SI: h = 0.137 m
base height, both links 0.105 m, 0.095 m wrist to tool); chain ``arm``: base_link -> noa.

Three target kinds:

- pose (SE3): :func:`pincher_pose`, 2 branches; a pose the arm cannot take (y axis not horizontal, or
  position off the arm plane of that yaw) has none: success=False, "unreachable".
- position + pitch (the seed's [px, py, pz, theta], :func:`position_pitch_branches`): q1 = atan2(py, px)
  with pitch theta, or q1 + pi with pitch pi - theta (same approach direction, tool rolled by pi);
  2 x 2 branches. :func:`pose_from_position_pitch` turns the seed's 4-vector into the SE3 the arm
  reaches with q1 = atan2(py, px).
- position only (3-vector): :func:`pincher_position`, the pitch nearest to q0's with a branch inside
  the limits (the family's rule).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import wbik.solvers.analytic.yaw_planar as family

BASE_HEIGHT = 0.137
LINK = 0.105
WRIST_TO_TOOL = 0.095
PINCHER = family.PitchArmGeometry(h=BASE_HEIGHT, a=LINK, b=LINK, t=WRIST_TO_TOOL)


def arm_plane_branches(yaw, signed_reach, height, pitch) -> tuple[np.ndarray, np.ndarray]:
    """Both elbow branches for a tool point at (signed_reach, height) of the plane of q1 = yaw with tool
    pitch ``pitch`` (broadcast to a shape S): (Q (S, 2, 4), real (S, 2))."""
    return family.pitch_arm_branches(PINCHER, yaw, signed_reach, height, pitch)


def position_pitch_branches(positions: np.ndarray, pitches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's inverse for [px, py, pz] (B, 3) in metres and pitch theta (B,) in radians.

    Returns (Q (B, 4, 4), real (B, 4)): branches q1 = atan2(py, px) (elbow q3 >= 0, then q3 <= 0),
    then q1 + pi with pitch pi - theta (both elbows). Angles are not wrapped into the limits.
    """
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    pitches = np.atleast_1d(np.asarray(pitches, dtype=float))
    yaws, reaches = family.shoulder_sides(positions)
    side_pitches = np.stack((pitches, np.pi - pitches), axis=1)
    q_all, real = arm_plane_branches(yaws, reaches, positions[:, 2, None], side_pitches)
    count = len(positions)
    return q_all.reshape(count, 4, 4), real.reshape(count, 4)


def pose_from_position_pitch(position, pitch: float) -> pin.SE3:
    """The noa pose for the seed's target [px, py, pz] (m) and tool pitch theta (rad), q1 = atan2(py, px)."""
    position = np.asarray(position, dtype=float)
    yaw = float(np.arctan2(position[1], position[0]))
    approach = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    side = np.array([np.sin(yaw), -np.cos(yaw), 0.0])
    return pin.SE3(np.column_stack((np.cross(side, approach), side, approach)), position)


def tool_fk(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form FK of the noa frame for joints (..., 4): positions (..., 3), rotations (..., 3, 3)."""
    return family.pitch_arm_fk(PINCHER, q)


def pincher_pose(chain) -> family.PitchArmPose:
    """Full-pose targets: q1 and the pitch from the rotation, 2 elbow branches (K = 2)."""
    return family.PitchArmPose(chain, PINCHER)


def pincher_position(chain) -> family.PitchArmPosition:
    """Position-only targets: the pitch nearest to q0's pitch with a branch inside the limits (K = 4)."""
    return family.PitchArmPosition(chain, PINCHER)
