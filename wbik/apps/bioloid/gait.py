"""The thesis's step forward (bioloid.md 4.4, 5.1): the code's gait numbers, key points (a leg's hip
relative to its ankle: x forward, y left, z up, m) and the 5 phases of ``StepForwardL`` (``StepForwardR``
taken as its mirror image); the sampled, timed motion the step generators produce; and (a), the step
generated faithfully as the code does: each division solved by the foot -> hip closed form (eq. 10-22) for
each leg on its own, so the legs do not form a closed chain, measured per sample (bioloid.md 4.5).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbik.apps.bioloid.servo import leg_ang_from_q, leg_q_from_ang, to_servo
from wbik.errors import InvalidConfigurationError
from wbik.motion.walking.footsteps import placed_on, sole_points, sole_polygon
from wbik.motion.walking.multibody_zmp import actuated_joints, limit_excess
from wbik.motion.walking.static_gait import SampledMotion, actuated_timing, pose_error
from wbik.motion.walking.zmp_timing import slowed_for_zmp
from wbik.robot import Robot
from wbik.robot_packages.bioloid.closed_form import leg_foot_to_hip

SIDES = ("r", "l")
SOLE = {"r": "r_sole", "l": "l_sole"}
HIP = {"r": "r_hip", "l": "l_hip"}
OTHER = {"r": "l", "l": "r"}
SIDE_NAME = {"r": "right", "l": "left"}


def start_q(robot, q0: np.ndarray | None = None) -> np.ndarray:
    """A copy of ``q0``, or of the robot's nominal configuration when None."""
    return (robot.nominal if q0 is None else np.asarray(q0, dtype=float)).copy()


@dataclass(frozen=True)
class GaitParameters:
    """The code's gait constants (bioloid.md 4.4; metres, degrees, seconds, rpm)."""

    xf: float = -0.030
    xb: float = 0.030
    xm: float = 0.000
    xu: float = -0.020
    yu: float = 0.030
    yd_out: float = 0.033
    yd_in: float = -0.018
    zu: float = 0.100
    zd: float = 0.140
    hip_pitch_deg: float = 20.0
    hip_roll_deg: float = 0.0
    divisions: int = 5
    division_delay_s: float = 0.100
    servo_fast_rpm: float = 40.0
    servo_slow_rpm: float = 10.0

    def __post_init__(self) -> None:
        if self.divisions < 1:
            raise InvalidConfigurationError(f"divisions must be >= 1, got {self.divisions}")
        if not self.zu < self.zd:
            raise InvalidConfigurationError(
                f"the lifted hip height zu ({self.zu}) must be below zd ({self.zd})")

    @property
    def pitch(self) -> float:
        """Torso pitch (rad)."""
        return math.radians(self.hip_pitch_deg)

    @property
    def roll(self) -> float:
        return math.radians(self.hip_roll_deg)

    @property
    def lift_height(self) -> float:
        """Foot clearance zd - zu (m)."""
        return self.zd - self.zu

    @property
    def step_length(self) -> float:
        """How far the lifted foot lands ahead of the other one, and the rear foot is dragged (m)."""
        return self.xm - self.xf

    @property
    def stride_length(self) -> float:
        """A left step plus a right step (m)."""
        return 2.0 * self.step_length

    def key_points(self) -> dict[str, np.ndarray]:
        """The code's key points by the code's names (hip relative to ankle, m)."""
        points = {
            "legDownForwardRight": (self.xf, self.yd_out, self.zd),
            "legDownBackwardRight": (self.xb, 0.0, self.zd),
            "legDownForwardLeft": (self.xf, -self.yd_out, self.zd),
            "legDownBackwardLeft": (self.xb, -self.yd_out, self.zd),
            "legUpMiddleRight": (self.xu, self.yu, self.zu),
            "legUpMiddleLeft": (self.xu, -self.yu, self.zu),
            "legDownStanding": (self.xm, 0.0, self.zd),
            "legDownMiddleRight": (self.xm, self.yd_in, self.zd),
            "legDownMiddleLeft": (self.xm, -self.yd_out, self.zd),
        }
        return {name: np.array(value, dtype=float) for name, value in points.items()}


@dataclass(frozen=True)
class GaitPhase:
    """One phase of a step: each leg's hip on a line from ``start`` to ``end`` (key points), the sides
    ``down``, ``lifted`` and ``dragged`` (sliding), the ``anchor`` sole held, the code's speed and pause."""

    name: str
    start: dict[str, np.ndarray]
    end: dict[str, np.ndarray]
    down: tuple[str, ...]
    lifted: str | None
    dragged: str | None
    anchor: str
    speed_rpm: float
    pause_s: float

    def hip_point(self, side: str, fraction: float) -> np.ndarray:
        """The code's linear interpolation p1 + (p2 - p1) * fraction of one leg's hip."""
        return self.start[side] + (self.end[side] - self.start[side]) * fraction

    def mirrored(self) -> GaitPhase:
        """The mirror image (y -> -y): legs swapped, lateral coordinates negated."""
        flip = np.array([1.0, -1.0, 1.0])
        swap = {**OTHER, None: None}
        return GaitPhase(self.name.replace("right", "@").replace("left", "right").replace("@", "left"),
                         {OTHER[s]: p * flip for s, p in self.start.items()},
                         {OTHER[s]: p * flip for s, p in self.end.items()},
                         tuple(OTHER[s] for s in self.down), swap[self.lifted], swap[self.dragged],
                         OTHER[self.anchor], self.speed_rpm, self.pause_s)


def step_forward_phases(gait: GaitParameters | None = None, first: str = "left") -> list[GaitPhase]:
    """The 5 phases of StepForwardL (``first="left"``) or its mirror image StepForwardR."""
    gait = gait or GaitParameters()
    k = gait.key_points()
    fast, slow = gait.servo_fast_rpm, gait.servo_slow_rpm

    def phase(name, right, left, down, lifted, dragged, anchor, speed, pause) -> GaitPhase:
        return GaitPhase(name, {"r": k[right[0]], "l": k[left[0]]}, {"r": k[right[1]], "l": k[left[1]]},
                         down, lifted, dragged, anchor, speed, pause)

    phases = [
        phase("shift the hips over the right foot", ("legDownStanding", "legDownMiddleRight"),
              ("legDownStanding", "legDownMiddleLeft"), ("r", "l"), None, None, "r", slow, 1.0),
        phase("lift the left foot", ("legDownMiddleRight", "legDownMiddleRight"),
              ("legDownMiddleLeft", "legUpMiddleLeft"), ("r",), "l", None, "r", fast, 0.0),
        phase("lower the left foot ahead", ("legDownMiddleRight", "legDownMiddleRight"),
              ("legUpMiddleLeft", "legDownForwardLeft"), ("r",), "l", None, "r", fast, 2.0),
        phase("move the hips over the front foot", ("legDownMiddleRight", "legDownBackwardRight"),
              ("legDownForwardLeft", "legDownStanding"), ("r", "l"), None, None, "r", slow, 2.0),
        phase("drag the rear foot forward", ("legDownBackwardRight", "legDownStanding"),
              ("legDownStanding", "legDownStanding"), ("r", "l"), None, "r", "l", slow, 1.0),
    ]
    key = str(first).lower()
    if key in ("left", "l"):
        return phases
    if key in ("right", "r"):
        return [phase.mirrored() for phase in phases]
    raise InvalidConfigurationError(f"first must be 'left' or 'right', got {first!r}")


@dataclass
class TimedMotion:
    """A sampled motion with a timing of its servo joints (the floating base is not commanded)."""

    motion: SampledMotion
    timed: object  # wbik.motion.TimedPath
    velocity_limit: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.timed.duration)

    @property
    def sample_times(self) -> np.ndarray:
        """Time at which each sample (knot) is reached."""
        return np.asarray(self.timed.knot_times, dtype=float)

    def evaluate(self, times) -> tuple[np.ndarray, np.ndarray]:
        """(joint angles, joint velocities) at the given times, each (len(times), 18)."""
        q, velocity, _ = self.timed.evaluate(np.asarray(times, dtype=float))
        return q, velocity

    def peak_velocity_ratio(self, step: float = 1e-3) -> float:
        """max_t max_j |dq_j/dt| / limit_j on a dense time grid (<= 1 when the limits hold)."""
        times = np.append(np.arange(0.0, self.duration, step), self.duration)
        _, velocity = self.evaluate(times)
        return float(np.max(np.abs(velocity) / self.velocity_limit))

    def servo_table(self, dt: float = 0.02) -> dict:
        """Servo goal positions (AX-12 units, IDs 1..18) every ``dt`` seconds, with clamping notes."""
        if not dt > 0:
            raise InvalidConfigurationError(f"dt must be positive, got {dt}")
        times = np.unique(np.append(np.arange(0.0, self.duration, dt), self.duration))
        q, _ = self.evaluate(times)
        names = self.motion.joint_names
        rows, clamped = [], {}
        for time, angles in zip(times, q, strict=True):
            command = to_servo(dict(zip(names, angles, strict=True)))
            rows.append([command.units[servo_id] for servo_id in range(1, 19)])
            for joint, (requested, applied) in command.clamped.items():
                clamped.setdefault(joint, []).append((float(time), requested, applied))
        return {"times_s": times, "ids": list(range(1, 19)), "units": np.array(rows, dtype=int),
                "clamped": clamped}

    def write_servo_csv(self, path, dt: float = 0.02) -> Path:
        """CSV: ``time_s, id_1 .. id_18`` (AX-12 units), one row per time step."""
        table = self.servo_table(dt)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["time_s", *[f"id_{i}" for i in table["ids"]]])
            for time, row in zip(table["times_s"], table["units"], strict=True):
                writer.writerow([f"{time:.4f}", *[int(v) for v in row]])
        return path


def time_scale_motion(motion: SampledMotion, speed_rpm: float | None = 40.0, law: str = "quintic",
                      mode: str = "segment", zmp_shift_max: float | None = None) -> TimedMotion:
    """Minimum-duration timing of the servos through every sample at ``speed_rpm`` (None: the URDF's
    limits): ``mode="segment"`` rests at every sample like the code's divisions (inside the joint limits),
    ``"waypoint"`` at phase ends only (faster; the spline may overshoot a limit between samples);
    ``zmp_shift_max`` (m): each piece slowed until the multibody ZMP stays that close to the CoM's ground
    projection (:mod:`wbik.motion.walking.zmp_timing`)."""
    if speed_rpm is not None and not speed_rpm > 0:
        raise InvalidConfigurationError(f"speed_rpm must be positive, got {speed_rpm}")
    model = motion.robot.model
    timed = actuated_timing(model, motion.q, speed_rpm, mode, motion.phase_end_samples(), law)
    if zmp_shift_max is not None:
        columns = [model.joints[j].idx_q for j in actuated_joints(model)]
        timed = slowed_for_zmp(motion.robot, motion.q, motion.support, timed, columns, zmp_shift_max)
    return TimedMotion(motion, timed, timed.velocity_limit)


def flatten_on_ground(placement: pin.SE3) -> pin.SE3:
    """The same x, y and yaw, on the ground (z = 0) and flat (no roll, no pitch)."""
    rotation = placement.rotation
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    flat = pin.utils.rotate("z", float(yaw))
    return pin.SE3(flat, np.array([placement.translation[0], placement.translation[1], 0.0]))


def _worst_inconsistency(samples: list[dict]) -> tuple[float | None, float | None]:
    double = [s for s in samples if s["inconsistency_mm"] is not None]
    return (max((s["inconsistency_mm"] for s in double), default=None),
            max((s["inconsistency_deg"] for s in double), default=None))


@dataclass
class FaithfulStep:
    """The faithful motion and its per-sample measurements (see the module docstring)."""

    motion: SampledMotion
    samples: list[dict] = field(default_factory=list)

    def summary(self) -> dict:
        lifted = [s["clearance_m"] for s in self.samples if s["clearance_m"] is not None]
        margins = [s["com_margin_m"] for s in self.samples]
        worst_mm, worst_deg = _worst_inconsistency(self.samples)
        return {
            "samples": len(self.samples),
            "max_inconsistency_mm": worst_mm or 0.0, "max_inconsistency_deg": worst_deg or 0.0,
            "min_com_margin_mm": 1e3 * min(margins),
            "samples_com_outside": int(sum(m < 0.0 for m in margins)),
            "min_clearance_mm": None if not lifted else 1e3 * min(lifted),
            "max_limit_excess_deg": float(np.degrees(max(s["limit_excess_rad"] for s in self.samples))),
            "unreachable_samples": int(sum(not s["reachable"] for s in self.samples)),
            "per_phase": self.per_phase(),
        }

    def per_phase(self) -> list[dict]:
        rows = []
        for index, name in enumerate(self.motion.phase_names):
            chosen = [s for s in self.samples if s["phase"] == index]
            worst_mm, worst_deg = _worst_inconsistency(chosen)
            rows.append({"phase": name, "max_inconsistency_mm": worst_mm, "max_inconsistency_deg": worst_deg,
                         "min_com_margin_mm": 1e3 * min(s["com_margin_m"] for s in chosen)})
        return rows


def step_forward_faithful(robot: Robot, gait: GaitParameters | None = None, first: str = "left",
                          q0: np.ndarray | None = None, round_degrees: bool = False) -> FaithfulStep:
    """The code's StepForwardL (its mirror: ``first="right"``) by the per-leg closed form from ``q0`` (default
    the nominal); ``round_degrees``: the code's ang[] rounded to whole degrees as the C code does."""
    gait = gait or GaitParameters()
    phases = step_forward_phases(gait, first)
    q = start_q(robot, q0)
    legs = {side: robot.chain(f"{SIDE_NAME[side]}_leg").q_index for side in SIDES}
    planted = {side: flatten_on_ground(robot.frame_placement(q, SOLE[side])) for side in SIDES}
    joint_index = np.concatenate(list(legs.values()))

    configurations, phase_of, support = [q.copy()], [-1], [("r_sole", "l_sole")]
    samples: list[dict] = []
    for index, phase in enumerate(phases):
        for division in range(1, gait.divisions + 1):
            fraction = division / gait.divisions
            reachable = True
            for side in SIDES:
                point = phase.hip_point(side, fraction)
                angles, ok = leg_foot_to_hip(point, 0.0, gait.pitch, gait.roll, side)
                if round_degrees:
                    angles = leg_q_from_ang(np.round(leg_ang_from_q(angles)))
                q[legs[side]] = angles
                reachable = reachable and bool(ok)
            q = placed_on(robot, q, SOLE[phase.anchor], planted[phase.anchor])
            sample = {"phase": index, "division": division, "reachable": reachable,
                      "inconsistency_mm": None, "inconsistency_deg": None, "clearance_m": None}
            down_soles = {}  # sole frame -> where it stands
            for side in phase.down:
                reached = robot.frame_placement(q, SOLE[side])
                if side == phase.anchor:
                    down_soles[SOLE[side]] = planted[side]
                    continue
                wanted = flatten_on_ground(reached) if side == phase.dragged else planted[side]
                position, rotation = pose_error(reached, wanted)
                sample["inconsistency_mm"] = 1e3 * position
                sample["inconsistency_deg"] = float(np.degrees(rotation))
                down_soles[SOLE[side]] = wanted
                if side == phase.dragged:
                    planted[side] = wanted
            if phase.lifted is not None:
                reached = robot.frame_placement(q, SOLE[phase.lifted])
                sample["clearance_m"] = float(np.min(sole_points(robot, SOLE[phase.lifted], reached)[:, 2]))
                if division == gait.divisions:  # touchdown: planted where it comes down
                    planted[phase.lifted] = flatten_on_ground(reached)
            sample["com_margin_m"] = sole_polygon(robot, down_soles).margin_of(robot.center_of_mass(q)[:2])
            sample["limit_excess_rad"] = limit_excess(robot.model, q, joint_index)
            samples.append(sample)
            configurations.append(q.copy())
            phase_of.append(index)
            support.append(tuple(SOLE[s] for s in phase.down))
    motion = SampledMotion(f"step_forward_{first}_faithful", robot, np.array(configurations),
                           np.array(phase_of), [p.name for p in phases], support)
    return FaithfulStep(motion, samples)
