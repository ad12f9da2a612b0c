"""The trajectory object: times, joints, the tip path achieved and its tracking error, written as ROS
``trajectory_msgs/JointTrajectory`` JSON or CSV."""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.files import atomic_write_text, json_plain
from wbik.motion.path import nanmax, tracking_errors
from wbik.motion.timing import TimedPath


@dataclass
class Trajectory:
    """Timed joint points of one chain with the achieved tip path and its tracking error."""

    robot: str
    chain: str
    base_frame: str
    tip_frame: str
    joint_names: list[str]
    times: np.ndarray  # (N,) s
    positions: np.ndarray  # (N, n) rad or m
    velocities: np.ndarray  # (N, n)
    accelerations: np.ndarray  # (N, n)
    tip_positions: np.ndarray  # (N, 3) m, FK in the chain's base frame
    tip_rotations: np.ndarray  # (N, 3, 3)
    position_errors: np.ndarray  # (N,) m against the task reference (NaN without one)
    rotation_errors: np.ndarray  # (N,) rad
    info: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    @property
    def max_position_error(self) -> float | None:
        return nanmax(self.position_errors)

    def summary(self) -> dict:
        return {"robot": self.robot, "chain": self.chain, "points": int(len(self.times)),
                "duration_s": self.duration, "max_position_error_m": self.max_position_error,
                "max_rotation_error_rad": nanmax(self.rotation_errors),
                "max_abs_velocity": np.max(np.abs(self.velocities), axis=0).tolist(),
                **{k: v for k, v in self.info.items() if k != "path"}}

    def to_joint_trajectory(self) -> dict:
        """A JSON-friendly dict in the shape of trajectory_msgs/JointTrajectory (+ a 'wbik' block)."""
        points = []
        for index, time in enumerate(self.times):
            whole = math.floor(time)
            seconds, nanoseconds = divmod(whole * 10**9 + round((time - whole) * 1e9), 10**9)
            points.append({"positions": self.positions[index].tolist(),
                           "velocities": self.velocities[index].tolist(),
                           "accelerations": self.accelerations[index].tolist(),
                           "time_from_start": {"sec": int(seconds), "nanosec": nanoseconds}})
        return {"header": {"frame_id": self.base_frame}, "joint_names": list(self.joint_names),
                "points": points,
                "wbik": {"robot": self.robot, "chain": self.chain, "tip_frame": self.tip_frame,
                         "times_s": self.times.tolist(), "tip_positions_m": self.tip_positions.tolist(),
                         "position_errors_m": json_plain(self.position_errors, finite=True),
                         "rotation_errors_rad": json_plain(self.rotation_errors, finite=True),
                         "summary": json_plain(self.summary(), finite=True)}}

    def write_json(self, path: str | Path) -> Path:
        atomic_write_text(Path(path), json.dumps(self.to_joint_trajectory(), indent=1))
        return Path(path)

    def write_csv(self, path: str | Path) -> Path:
        """Columns time_s, the joints, their _velocity and _acceleration, tip_x/y/z, position_error_m,
        rotation_error_rad."""
        names = self.joint_names
        text = io.StringIO()
        writer = csv.writer(text)
        writer.writerow(["time_s", *names, *[f"{n}_velocity" for n in names],
                         *[f"{n}_acceleration" for n in names], "tip_x", "tip_y", "tip_z",
                         "position_error_m", "rotation_error_rad"])
        for index, time in enumerate(self.times):
            values = np.r_[self.positions[index], self.velocities[index], self.accelerations[index],
                           self.tip_positions[index]]
            errors = ["" if np.isnan(e) else f"{e:.9g}"
                      for e in (self.position_errors[index], self.rotation_errors[index])]
            writer.writerow([f"{time:.9f}", *[f"{v:.12g}" for v in values], *errors])
        atomic_write_text(Path(path), text.getvalue())
        return Path(path)


def make_trajectory(timed: TimedPath, dt: float | None = None, times=None) -> Trajectory:
    """Sample ``timed`` at its knot times (default), every ``dt`` s (end included) or at ``times``."""
    if times is not None:
        times = np.asarray(times, dtype=float)
    elif dt is not None:
        if not dt > 0:
            raise InvalidConfigurationError(f"dt must be positive, got {dt}")
        times = np.unique(np.append(np.arange(0.0, timed.duration, dt), timed.duration))
    else:
        times = timed.knot_times.copy()
    positions, velocities, accelerations = timed.evaluate(times)
    chain = timed.path.chain
    tips = [chain.fk(q) for q in positions]
    if timed.path.reference is not None:
        position_errors, rotation_errors = tracking_errors(chain, timed.path.reference,
                                                           timed.parameter(times), positions)
    else:
        position_errors = rotation_errors = np.full(len(times), np.nan)
    info = {"time_law": timed.law.name, "timing_mode": timed.mode,
            "velocity_limit": timed.velocity_limit.tolist(),
            "acceleration_limit": json_plain(timed.acceleration_limit), "path": timed.path.summary()}
    return Trajectory(chain.robot.name, chain.name, chain.base_frame, chain.tip_frame,
                      list(chain.joint_names), times, positions, velocities, accelerations,
                      np.array([pose.translation for pose in tips]),
                      np.array([pose.rotation for pose in tips]), position_errors, rotation_errors, info)
