"""PhantomX Pincher binding (pincher.md's inverse): the yaw + planar 2R + wrist pitch member of the
yaw-planar family (:mod:`wbik.solvers.analytic.yaw_planar`), chain ``arm`` (base_link -> noa): full poses
(:func:`pincher_pose`, none for a pose off the arm's reach), the seed's position + pitch
(:func:`position_pitch_branches`) and positions (:func:`pincher_position`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import wbik.solvers.analytic.yaw_planar as family

BASE_HEIGHT = 0.137  # m
LINK = 0.105  # both links (m)
WRIST_TO_TOOL = 0.095  # m
PINCHER = family.PitchArmGeometry(h=BASE_HEIGHT, a=LINK, b=LINK, t=WRIST_TO_TOOL)


def position_pitch_branches(positions: np.ndarray, pitches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The seed's inverse for [px, py, pz] (B, 3) (m) and pitch theta (B,) (rad): (Q (B, 4, 4), real
    (B, 4)), q1 = atan2(py, px) (elbow q3 >= 0, then <= 0), then q1 + pi with pitch pi - theta; unwrapped."""
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    pitches = np.atleast_1d(np.asarray(pitches, dtype=float))
    yaws, reaches = family.shoulder_sides(positions)
    side_pitches = np.stack((pitches, np.pi - pitches), axis=1)
    q_all, real = family.pitch_arm_branches(PINCHER, yaws, reaches, positions[:, 2, None], side_pitches)
    count = len(positions)
    return q_all.reshape(count, 4, 4), real.reshape(count, 4)


def pose_from_position_pitch(position, pitch: float) -> pin.SE3:
    """The noa pose for the seed's [px, py, pz] (m) and tool pitch theta (rad), q1 = atan2(py, px)."""
    position = np.asarray(position, dtype=float)
    yaw = float(np.arctan2(position[1], position[0]))
    approach = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    side = np.array([np.sin(yaw), -np.cos(yaw), 0.0])
    return pin.SE3(np.column_stack((np.cross(side, approach), side, approach)), position)


def pincher_pose(chain) -> family.PitchArmPose:
    """Full poses: q1 and the pitch from the rotation, 2 elbow branches."""
    return family.PitchArmPose(chain, PINCHER)


def pincher_position(chain) -> family.PitchArmPosition:
    """Positions: the pitch nearest to q0's with a branch inside the limits (4 branches)."""
    return family.PitchArmPosition(chain, PINCHER)
