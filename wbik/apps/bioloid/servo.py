"""Bioloid joint angles (rad) <-> Dynamixel AX-12 positions (0..1023 units over 0..300 deg; bioloid.md 1.2,
1.6, 2.4, 3.6): ``servo_deg = offset + direction * degrees(q)`` per servo, the code's IKAdjust6ServoLeg and
IKAdjust3ServoArm composed with the model's joint convention; the left arm (ASSUMED: the thesis gives the
right only) mirrors the right, and the left rolls' limits are mirrored (the code's are not, bioloid.md 9.6;
its own pipeline :func:`code_leg_servo_degrees` keeps them). Clamping is reported, never silent.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from wbik.errors import InvalidConfigurationError

FULL_SCALE_DEG = 300.0
FULL_SCALE_UNITS = 1023
DEG_PER_UNIT = FULL_SCALE_DEG / FULL_SCALE_UNITS


@dataclass(frozen=True)
class ServoJoint:
    """One joint's servo: ``servo_deg = offset_deg + direction * degrees(q)``, clamped to [min, max]."""

    joint: str
    servo_id: int
    offset_deg: float
    direction: int
    min_deg: float
    max_deg: float

    def servo_degrees(self, q: float) -> float:
        return self.offset_deg + self.direction * math.degrees(q)

    def joint_angle(self, servo_deg: float) -> float:
        return math.radians((servo_deg - self.offset_deg) * self.direction)


SERVOS = {row[0]: ServoJoint(*row) for row in (  # joint, id, offset, direction, min, max (servo degrees)
    ("r_shoulder_pitch", 1, 62.0, 1, 0.0, 300.0), ("l_shoulder_pitch", 2, 238.0, -1, 0.0, 300.0),
    ("r_shoulder_roll", 3, 150.0, 1, 60.0, 240.0), ("l_shoulder_roll", 4, 150.0, 1, 60.0, 240.0),
    ("r_elbow", 5, 150.0, 1, 60.0, 240.0), ("l_elbow", 6, 150.0, 1, 60.0, 240.0),
    ("r_hip_yaw", 7, 105.0, -1, 55.0, 160.0), ("l_hip_yaw", 8, 195.0, -1, 140.0, 245.0),
    ("r_hip_roll", 9, 150.0, 1, 100.0, 190.0), ("l_hip_roll", 10, 150.0, 1, 110.0, 200.0),
    ("r_hip_pitch", 11, 150.0, 1, 50.0, 175.0), ("l_hip_pitch", 12, 150.0, -1, 125.0, 250.0),
    ("r_knee", 13, 150.0, -1, 46.0, 160.0), ("l_knee", 14, 150.0, 1, 140.0, 254.0),
    ("r_ankle_pitch", 15, 150.0, -1, 120.0, 210.0), ("l_ankle_pitch", 16, 150.0, 1, 90.0, 180.0),
    ("r_ankle_roll", 17, 150.0, -1, 110.0, 180.0), ("l_ankle_roll", 18, 150.0, -1, 120.0, 190.0),
)}
BY_ID = {servo.servo_id: servo for servo in SERVOS.values()}
READY_POSE_UNITS = (235, 788, 279, 744, 462, 561, 358, 666, 507, 516, 341, 682, 240, 783, 647, 376, 507, 516)
"""The code's Robot_ready_pos (bioloid.md 1.7): raw AX-12 units of IDs 1..18."""
LEG_ORDER = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
CODE_LEG_LIMITS = {  # the code's own leg limits (servo degrees) as written (rolls not mirrored)
    "r": ((55, 160), (100, 190), (50, 175), (46, 160), (120, 210), (110, 180)),
    "l": ((140, 245), (100, 190), (125, 250), (140, 254), (90, 180), (110, 180)),
}
CODE_LEG_DEFAULT = (105, 150, 150, 150, 150, 150)
"""What the code writes for a value outside [0, 300] on either leg: 150, and 105 for the yaw (a bug on the
left)."""


def units_to_degrees(units) -> np.ndarray:
    """AX-12 units (0..1023) -> servo degrees (0..300)."""
    return np.asarray(units, dtype=float) * DEG_PER_UNIT


def degrees_to_units(servo_deg) -> np.ndarray:
    """Servo degrees -> nearest AX-12 units (int), not clamped."""
    return np.rint(np.asarray(servo_deg, dtype=float) / DEG_PER_UNIT).astype(int)


def c_round(value) -> np.ndarray:
    """C's round(): halves away from zero (the author's code rounds degrees this way)."""
    value = np.asarray(value, dtype=float)
    return (np.sign(value) * np.floor(np.abs(value) + 0.5)).astype(int)


@dataclass
class ServoCommand:
    """Servo goal positions: ``degrees``/``units`` servo ID -> position after clamping, ``clamped``
    joint -> (requested, applied) servo degrees, ``out_of_range`` the joints requested outside 0..300 deg
    (the code calls them unreachable)."""

    degrees: dict[int, float] = field(default_factory=dict)
    units: dict[int, int] = field(default_factory=dict)
    clamped: dict[str, tuple[float, float]] = field(default_factory=dict)
    out_of_range: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.clamped and not self.out_of_range


def to_servo(joint_angles: Mapping[str, float]) -> ServoCommand:
    """Joint angles (rad, by joint name) -> clamped servo positions, with a report of the clamping."""
    command = ServoCommand()
    for joint, q in joint_angles.items():
        if joint not in SERVOS:
            raise InvalidConfigurationError(f"{joint!r} is not a Bioloid servo joint; known: "
                                            f"{', '.join(SERVOS)}")
        if not np.isfinite(q):
            raise InvalidConfigurationError(f"joint {joint!r} has a non-finite angle {q!r}")
        servo = SERVOS[joint]
        requested = servo.servo_degrees(float(q))
        applied = min(max(requested, servo.min_deg), servo.max_deg)
        if not 0.0 <= requested <= FULL_SCALE_DEG:
            command.out_of_range.append(joint)
        if applied != requested:
            command.clamped[joint] = (requested, applied)
        command.degrees[servo.servo_id] = applied
        command.units[servo.servo_id] = int(degrees_to_units(applied))
    return command


def from_servo_units(units: Mapping[int, int] | np.ndarray) -> dict[str, float]:
    """Servo positions (ID -> units, or an array of 18 units for IDs 1..18) -> joint angles (rad)."""
    if not isinstance(units, Mapping):
        values = np.asarray(units)
        if values.shape != (18,):
            raise InvalidConfigurationError(f"expected 18 servo positions (IDs 1..18), got {values.shape}")
        units = {i + 1: int(v) for i, v in enumerate(values)}
    angles = {}
    for servo_id, value in units.items():
        if servo_id not in BY_ID:
            raise InvalidConfigurationError(f"servo ID {servo_id} is not one of the Bioloid's IDs 1..18")
        if not 0 <= value <= FULL_SCALE_UNITS:
            raise InvalidConfigurationError(f"servo {servo_id}: {value} units is outside 0..1023")
        servo = BY_ID[servo_id]
        angles[servo.joint] = servo.joint_angle(float(units_to_degrees(value)))
    return angles


LEG_ANG_SIGNS = np.array([-1, -1, -1, -1, -1, 1.0])  # the code's ang[] = degrees(q) * these


def leg_ang_from_q(q) -> np.ndarray:
    """Leg joint angles (..., 6) rad -> the code's ang[] (degrees)."""
    return np.degrees(np.asarray(q, dtype=float)) * LEG_ANG_SIGNS


def leg_q_from_ang(ang_deg) -> np.ndarray:
    """The code's ang[] (degrees) -> leg joint angles (rad)."""
    return np.radians(np.asarray(ang_deg, dtype=float) * LEG_ANG_SIGNS)


def code_leg_servo_degrees(ang_deg, side: str) -> tuple[np.ndarray, list[str]]:
    """The code's IKAdjust6ServoLeg on integer ang[]: servo degrees (6 ints) and a note per joint
    clamped to the code's limits or reset to its default (outside 0..300)."""
    if str(side).lower() not in ("r", "l", "right", "left"):
        raise InvalidConfigurationError(f"side must be 'right' or 'left', got {side!r}")
    side = str(side).lower()[0]
    leg_dir = 1 if side == "r" else -1
    a = c_round(ang_deg)
    raw = [150 - leg_dir * 45 + a[0], 150 - a[1], 150 - leg_dir * a[2], 150 + leg_dir * a[3],
           150 + leg_dir * a[4], 150 - a[5]]
    notes: list[str] = []
    servo = [_code_corrected(f"{side}_{name}", value, low, high, default, notes)
             for name, value, (low, high), default in zip(LEG_ORDER, raw, CODE_LEG_LIMITS[side],
                                                          CODE_LEG_DEFAULT, strict=True)]
    return np.array(servo), notes


def _code_corrected(name: str, value, low, high, default, notes: list[str]) -> int:
    """A servo value as the author's code corrects it (outside 0..300 reset to ``default``, else clamped
    to [low, high]), each correction noted."""
    if not 0 <= value <= 300:
        notes.append(f"{name}: {value} outside 0..300, reset to {default}")
        return int(default)
    if value < low or value > high:
        clamped = min(max(value, low), high)
        notes.append(f"{name}: clamped from {value} to {clamped}")
        value = clamped
    return int(value)


def code_arm_servo_degrees(theta_deg) -> tuple[np.ndarray, list[str]]:
    """The code's IKAdjust3ServoArm (right arm) on (theta1, theta3, theta5) degrees, with notes:
    base = round(theta1) + 62 (never corrected), shoulder and elbow = 150 - round(theta), outside
    0..300 -> 150, then clamped to [60, 240]."""
    t1, t3, t5 = c_round(theta_deg)
    base = 152 - (90 - t1)
    notes = [] if 0 <= base <= 300 else [f"base {base} outside 0..300 (the code leaves it)"]
    out = [int(base), *(_code_corrected(name, value, 60, 240, 150, notes)
                        for name, value in (("shoulder", 150 - t3), ("elbow", 150 - t5)))]
    return np.array(out), notes
