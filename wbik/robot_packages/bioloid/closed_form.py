"""Closed-form IK of the Bioloid's arms and legs (bioloid.md 2 and 3), vectorised over batches, and the
dimensions and facts the robot is built with.

The thesis's equations (rad, any batch shape): :func:`arm_thesis_angles` (eq. 1-9, the code's eq. 8)
and :func:`leg_thesis_angles` (eq. 10-22 foot -> hip, eq. 22 with "- alpha"). Unreachable targets get
the clamped cosine (the nearest stretched limb, never NaN) and a ``reachable`` mask. The closed forms
:class:`ArmPosition`, :class:`LegPose` and :class:`LegPosition` give every exact branch, the thesis's first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbik.errors import InvalidTargetError
from wbik.geometry import rot_x, rot_y, rot_z
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.subproblems import clamped_acos, clamped_cosine
from wbik.validation import numeric_array

L0, L1, L2, L3 = 0.047, 0.0145, 0.025, 0.0675  # the seed's arm lengths (m)
FOREARM = 0.0745
TOOL_CODE = 0.0255  # hand/tool length of the author's code (L4 = 0.100 m), the default
TOOL_THESIS = 0.070  # hand/tool length of the thesis's Table 1 (L4 = 0.1445 m)
L7, L8 = 0.0145, 0.075
LF = math.hypot(L7, L8)
ALPHA = math.atan2(L7, L8)

LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
ARM_JOINTS = ("shoulder_pitch", "shoulder_roll", "elbow")

MIRROR_SIGN = {"shoulder_pitch": 1.0, "shoulder_roll": -1.0, "elbow": -1.0, "hip_yaw": -1.0,
               "hip_roll": -1.0, "hip_pitch": 1.0, "knee": 1.0, "ankle_pitch": 1.0, "ankle_roll": -1.0}
"""q_left = sign * q_right for the mirror image (y -> -y) of a right-side pose (same axes both sides)."""


def arm_lengths(tool_length: float = TOOL_CODE) -> tuple[float, float, float, float, float]:
    """(L0, L1, L2, L3, L4) in metres; L4 = 0.0745 + tool (code 0.0255 -> 0.100, thesis 0.070)."""
    return (L0, L1, L2, L3, FOREARM + tool_length)


@dataclass(frozen=True)
class BioloidFacts:
    """What a Bioloid robot was built with (``robot.facts``; m, rad): the seed's ``servo_ids`` (joint ->
    Dynamixel ID), ``mirror_sign`` (q_left = s q_right), ``arm_lengths`` (L0..L4, L4 = 0.0745 + tool),
    ``tool_length``, the nominal's ``standing_hip_height`` (the code's zd) and ``standing_pitch``, and
    ASSUMPTIONS: ``hip_lateral`` (pelvis centre -> hip, sideways), ``hip_drop`` (pelvis origin -> hip,
    down), ``ankle_height`` (ankle axes -> sole), ``chest_height`` (pelvis origin -> chest centre, up),
    ``sole_size`` (length, width of the sole rectangle under the ankle), masses (see the URDF)."""

    servo_ids: dict[str, int]
    mirror_sign: dict[str, float]
    arm_lengths: tuple[float, float, float, float, float]
    tool_length: float
    standing_hip_height: float
    standing_pitch: float
    hip_lateral: float
    hip_drop: float
    ankle_height: float
    chest_height: float
    sole_size: tuple[float, float]


ARM_MIRROR = np.array([MIRROR_SIGN[joint] for joint in ARM_JOINTS])


def _points(p, what: str) -> np.ndarray:
    array = numeric_array(p, what, InvalidTargetError)
    if array.shape[-1:] != (3,):
        raise InvalidTargetError(f"{what} must have 3 coordinates (shape (..., 3)), got shape {array.shape}")
    return array


def _side(side: str) -> str:
    key = str(side).lower()
    if key not in ("r", "right", "l", "left"):
        raise InvalidTargetError(f"side must be 'right'/'r' or 'left'/'l', got {side!r}")
    return key[0]


@dataclass(frozen=True)
class ArmAngles:
    """Eq. 1-9 intermediates and outputs (rad, m) for a batch of right-hand targets (bioloid.md 2.2-2.3)."""

    theta1: np.ndarray
    theta3: np.ndarray
    theta5: np.ndarray
    t: np.ndarray
    s: np.ndarray
    reach: np.ndarray
    c5: np.ndarray
    reachable: np.ndarray


def arm_thesis_angles(p_hand, lengths=None, other_elbow: bool = False, base_flip: bool = False) -> ArmAngles:
    """Right-arm IK, eq. 1-9 with the code's eq. 8: gamma2 = atan2(L4 sin(-theta5), L3 + L4 cos(-theta5));
    ``other_elbow``: theta5 >= 0, ``base_flip``: the base turned by pi (both False: the thesis's)."""
    l0, l1, l2, l3, l4 = arm_lengths() if lengths is None else lengths
    p = _points(p_hand, "hand target")
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    theta1 = np.arctan2(z, x)                                   # eq. 1
    radial = np.hypot(x, z)
    if base_flip:
        theta1, radial = theta1 + np.pi, -radial
    t = -y - l0 - l1                                            # eq. 2
    s = radial - l2                                             # eq. 3
    reach = np.hypot(s, t)                                      # eq. 4
    c5, reachable = clamped_cosine((reach ** 2 - l3 ** 2 - l4 ** 2) / (2 * l3 * l4))   # eq. 5
    theta5 = -np.arctan2(np.sqrt(1.0 - c5 ** 2), c5)            # eq. 6
    if other_elbow:
        theta5 = -theta5
    gamma1 = np.arctan2(s, t)                                   # eq. 7
    gamma2 = np.arctan2(l4 * np.sin(-theta5), l3 + l4 * np.cos(-theta5))   # eq. 8 (code)
    theta3 = -(gamma1 - gamma2)                                 # eq. 9
    return ArmAngles(theta1, theta3, theta5, t, s, reach, c5, reachable)


def arm_ik(p_hand, side: str = "right", lengths=None, other_elbow: bool = False,
           base_flip: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Joints (..., 3) of the arm chain (chest -> hand), reachable mask (flags: :func:`arm_thesis_angles`)."""
    side = _side(side)
    p = _points(p_hand, "hand target")
    if side == "l":
        p = p * np.array([1.0, -1.0, 1.0])
    a = arm_thesis_angles(p, lengths, other_elbow, base_flip)
    q = np.stack([a.theta1, -a.theta3, -a.theta5], -1)
    return (q * ARM_MIRROR if side == "l" else q), a.reachable


def arm_fk(q, side: str = "right", lengths=None) -> tuple[np.ndarray, np.ndarray]:
    """Hand position (..., 3) and orientation (..., 3, 3) in the chest frame."""
    l0, l1, l2, l3, l4 = arm_lengths() if lengths is None else lengths
    q = np.asarray(q, dtype=float)
    left = _side(side) == "l"
    if left:
        q = q * ARM_MIRROR
    q1, q3, q5 = q[..., 0], q[..., 1], q[..., 2]
    t = l3 * np.cos(q3) + l4 * np.cos(q3 + q5)
    s = l3 * np.sin(q3) + l4 * np.sin(q3 + q5)
    radial = l2 + s
    p = np.stack([radial * np.cos(q1), -(l0 + l1) - t, radial * np.sin(q1)], -1)
    rotation = rot_y(-q1) @ rot_z(q3 + q5)
    if left:
        mirror = np.diag([1.0, -1.0, 1.0])
        p = p @ mirror
        rotation = mirror @ rotation @ mirror
    return p, rotation


@dataclass(frozen=True)
class LegAngles:
    """Eq. 10-22 intermediates and outputs (rad) for a batch of hip targets (bioloid.md 3.2-3.6)."""

    gamma: np.ndarray
    beta: np.ndarray
    theta7: np.ndarray
    theta9: np.ndarray
    theta11: np.ndarray
    theta13: np.ndarray
    theta15: np.ndarray
    theta17: np.ndarray
    reachable: np.ndarray

    @property
    def ang(self) -> np.ndarray:
        """The code's ang[] (degrees, unrounded): [th7, th9, 90 - th11, -(180 - th13), 90 - th15, th17]."""
        d = np.degrees
        return np.stack([d(self.theta7), d(self.theta9), 90.0 - d(self.theta11), d(self.theta13) - 180.0,
                         90.0 - d(self.theta15), d(self.theta17)], -1)

    @property
    def q(self) -> np.ndarray:
        """Joint angles (..., 6) of the leg chain (hip yaw, roll, pitch, knee, ankle pitch, roll)."""
        return np.stack([-self.theta7, -self.theta9, self.theta11 - np.pi / 2, np.pi - self.theta13,
                         self.theta15 - np.pi / 2, self.theta17], -1)


def leg_thesis_angles(p_hip, yaw=0.0, pitch=0.0, roll=0.0) -> LegAngles:
    """Foot -> hip IK, eq. 10-22 (eq. 22 with "- alpha"). ``p_hip``: hip point in the ankle frame (m)."""
    p = _points(p_hip, "hip target")
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    theta17 = np.arctan2(y, z)                                          # eq. 10
    length = np.linalg.norm(p, axis=-1)                                 # eq. 11
    cos_gamma, reachable = clamped_cosine((length ** 2 - 2 * LF ** 2) / (-2 * LF ** 2))   # eq. 12-13
    gamma = np.arctan2(np.sqrt(1.0 - cos_gamma ** 2), cos_gamma)        # eq. 14
    theta13 = gamma - 2 * ALPHA                                         # eq. 15-16
    beta = np.arctan2(x, np.hypot(z, y))                                # eq. 17-18
    theta15 = -(beta - gamma / 2 + ALPHA)                               # eq. 19
    theta7 = np.broadcast_to(np.asarray(yaw, dtype=float), theta17.shape) * 1.0   # eq. 20
    theta9 = roll + theta17                                             # eq. 21
    theta11 = -pitch + beta + gamma / 2 - ALPHA                         # eq. 22 (code)
    return LegAngles(gamma, beta, theta7, theta9, theta11, theta13, theta15, theta17, reachable)


def leg_foot_to_hip(p_hip, yaw=0.0, pitch=0.0, roll=0.0,
                    side: str = "right") -> tuple[np.ndarray, np.ndarray]:
    """(q (..., 6), reachable) putting the hip at ``p_hip`` (ankle frame, m) with the thesis's yaw, pitch,
    roll (rad); both legs use the same equations (``side`` is only checked)."""
    _side(side)
    angles = leg_thesis_angles(p_hip, yaw, pitch, roll)
    return angles.q, angles.reachable


THIGH = np.array([-L7, 0.0, -L8])
"""Hip point -> knee rotor in the thigh frame (rotor L7 behind the leg line)."""
SHANK = np.array([L7, 0.0, -L8])
"""Knee rotor -> ankle point in the shank frame."""


def leg_fk(q) -> tuple[np.ndarray, np.ndarray]:
    """Ankle position (..., 3) and rotation (..., 3, 3) in the hip frame (same for both legs)."""
    q = np.asarray(q, dtype=float)
    upper = rot_z(q[..., 0]) @ rot_x(q[..., 1])
    thigh = upper @ rot_y(q[..., 2])
    shank = thigh @ rot_y(q[..., 3])
    p = thigh @ THIGH + shank @ SHANK
    return p, shank @ rot_y(q[..., 4]) @ rot_x(q[..., 5])


def leg_branches(p_hip: np.ndarray, r_hip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Q (B, 4, 6), reachable (B, 4)): every exact solution for the hip pose (p_hip, r_hip) in the ankle
    frame, branch 0 the thesis's. hip = -Rx(-q17) Ry(-q15) (SHANK + Ry(-q13) THIGH) gives the ankle roll,
    the knee (triangle Lf, Lf, |p|) and the ankle pitch; Ry(q13 + q15) Rx(q17) R_hip =
    Ry(-q11) Rx(-q9) Rz(-q7) the hip's Y-X-Z Euler angles."""
    x, y, z = p_hip[:, 0], p_hip[:, 1], p_hip[:, 2]
    q17 = np.arctan2(y, z)
    beta = np.arctan2(x, np.hypot(y, z))
    length = np.linalg.norm(p_hip, axis=-1)
    gamma, reachable = clamped_acos((length ** 2 - 2 * LF ** 2) / (-2 * LF ** 2))
    solutions = []
    for knee in (np.pi + 2 * ALPHA - gamma, gamma - np.pi + 2 * ALPHA):
        c = SHANK + rot_y(-knee) @ THIGH
        q15 = np.arctan2(-c[:, 0], -c[:, 2]) - beta
        m = rot_y(knee + q15) @ rot_x(q17) @ r_hip
        cos_b = np.hypot(m[:, 1, 0], m[:, 1, 1])
        for sign in (1.0, -1.0):
            b = np.arctan2(-m[:, 1, 2], sign * cos_b)
            a = np.arctan2(sign * m[:, 0, 2], sign * m[:, 2, 2])
            c_angle = np.arctan2(sign * m[:, 1, 0], sign * m[:, 1, 1])
            solutions.append(np.stack([-c_angle, -b, -a, knee, q15, q17], -1))
    return np.stack(solutions, 1), np.repeat(reachable[:, None], len(solutions), axis=1)


class ArmPosition(ClosedForm):
    """Hand position of ``right_arm``/``left_arm`` (chest frame): 4 exact branches, thesis first."""

    target_kind = "position"
    geometry_fk = staticmethod(lambda side_lengths, q: arm_fk(q, *side_lengths))

    def __init__(self, chain):
        lengths = chain.robot.require_facts(BioloidFacts, "the Bioloid arm closed form").arm_lengths
        super().__init__(chain, ("l" if chain.joint_names[0].startswith("l_") else "r", lengths))

    def branches(self, positions, rotations, q0):
        branches = [arm_ik(positions, *self.geometry, other_elbow, base_flip)
                    for base_flip in (False, True) for other_elbow in (False, True)]
        return np.stack([q for q, _ in branches], 1), np.stack([real for _, real in branches], 1)


class LegPose(ClosedForm):
    """Ankle pose in the hip frame (``right_leg``/``left_leg``): the foot -> hip problem inverted."""

    geometry = None  # both legs: THIGH, SHANK
    geometry_fk = staticmethod(lambda _, q: leg_fk(q))

    def branches(self, positions, rotations, q0):
        r_hip = np.swapaxes(rotations, -1, -2)
        p_hip = -np.einsum("bij,bj->bi", r_hip, positions)
        return leg_branches(p_hip, r_hip)


def leg_position_branches_keeping_ankle(p_ankle: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Q (B, 4, 6), reachable (B, 4)) for the ankle position (B, 3) in the hip frame with q0's yaw and
    ankle joints: u = Rz(-q7) p, the hip roll puts u in the leg plane (2 signs), the knee from the Lf
    triangle (2 branches), the hip pitch turns d = THIGH + Ry(q13) SHANK onto u."""
    u = np.einsum("bji,bj->bi", rot_z(q0[:, 0]), p_ankle)       # Rz(-q7) p
    length = np.linalg.norm(p_ankle, axis=-1)
    gamma, reachable = clamped_acos((length ** 2 - 2 * LF ** 2) / (-2 * LF ** 2))
    rho = np.hypot(u[:, 1], u[:, 2])
    solutions = []
    for down in (1.0, -1.0):
        q9 = np.arctan2(down * u[:, 1], -down * u[:, 2])
        in_plane_z = -down * rho
        for knee in (np.pi + 2 * ALPHA - gamma, gamma - np.pi + 2 * ALPHA):
            d = THIGH + rot_y(knee) @ SHANK
            q11 = np.arctan2(u[:, 0], in_plane_z) - np.arctan2(d[:, 0], d[:, 2])
            solutions.append(np.stack([q0[:, 0], q9, q11, knee, q0[:, 4], q0[:, 5]], -1))
    return np.stack(solutions, 1), np.repeat(reachable[:, None], len(solutions), axis=1)


class LegPosition(LegPose):
    """Ankle position in the hip frame, 12 branches: foot parallel to the hip (0-3, branch 0 the
    thesis's), foot at q0's orientation (4-7), q0's hip yaw and ankle joints kept (8-11)."""

    target_kind = "position"

    def branches(self, positions, rotations, q0):
        identity = np.broadcast_to(np.eye(3), (len(positions), 3, 3))
        q_parallel, ok_parallel = leg_branches(-positions, identity)
        q_kept, ok_kept = super().branches(positions, leg_fk(q0)[1], q0)
        q_hip, ok_hip = leg_position_branches_keeping_ankle(positions, q0)
        return (np.concatenate([q_parallel, q_kept, q_hip], 1),
                np.concatenate([ok_parallel, ok_kept, ok_hip], 1))
