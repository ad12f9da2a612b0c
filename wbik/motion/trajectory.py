"""The trajectory object: times, joints, the tip path actually achieved, the tracking error, and
export in the shape of a ROS ``trajectory_msgs/JointTrajectory`` (CSV or JSON).

JSON shape: ``{"joint_names": [...], "points": [{"positions", "velocities", "accelerations",
"time_from_start": {"sec", "nanosec"}}, ...]}`` plus a ``wbik`` block with the achieved tip path,
the errors and the timing facts. CSV: one row per point, columns ``time_s``, the joint names
(positions), ``<joint>_velocity``, ``<joint>_acceleration``, ``tip_x/y/z`` (m),
``position_error_m`` and ``rotation_error_rad`` (empty when there is no task reference).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from dataclasses import field
from pathlib import Path

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.files import json_plain
from wbik.motion.path import tracking_errors
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
        """Seconds from the first point to the last."""
        return float(self.times[-1] - self.times[0])

    @property
    def max_position_error(self) -> float | None:
        return None if np.all(np.isnan(self.position_errors)) else float(np.nanmax(self.position_errors))

    @property
    def max_rotation_error(self) -> float | None:
        return None if np.all(np.isnan(self.rotation_errors)) else float(np.nanmax(self.rotation_errors))

    def summary(self) -> dict:
        return {"robot": self.robot, "chain": self.chain, "points": int(len(self.times)),
                "duration_s": self.duration, "max_position_error_m": self.max_position_error,
                "max_rotation_error_rad": self.max_rotation_error,
                "max_abs_velocity": [float(v) for v in np.max(np.abs(self.velocities), axis=0)],
                **{k: v for k, v in self.info.items() if k != "path"}}

    def to_joint_trajectory(self) -> dict:
        """A JSON-friendly dict in the shape of trajectory_msgs/JointTrajectory (+ a 'wbik' block)."""
        points = []
        for index, time in enumerate(self.times):
            seconds = math.floor(time)
            nanoseconds = int(round((time - seconds) * 1e9))
            if nanoseconds == 1_000_000_000:
                seconds, nanoseconds = seconds + 1, 0
            points.append({
                "positions": [float(v) for v in self.positions[index]],
                "velocities": [float(v) for v in self.velocities[index]],
                "accelerations": [float(v) for v in self.accelerations[index]],
                "time_from_start": {"sec": int(seconds), "nanosec": nanoseconds},
            })
        return {
            "header": {"frame_id": self.base_frame},
            "joint_names": list(self.joint_names),
            "points": points,
            "wbik": {
                "robot": self.robot, "chain": self.chain, "tip_frame": self.tip_frame,
                "times_s": [float(t) for t in self.times],
                "tip_positions_m": self.tip_positions.tolist(),
                "position_errors_m": [None if np.isnan(e) else float(e) for e in self.position_errors],
                "rotation_errors_rad": [None if np.isnan(e) else float(e) for e in self.rotation_errors],
                "summary": json_plain(self.summary(), finite=True),
            },
        }

    def write_json(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_joint_trajectory(), indent=1))
        return path

    def write_csv(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        names = self.joint_names
        header = (["time_s", *names, *[f"{n}_velocity" for n in names],
                   *[f"{n}_acceleration" for n in names], "tip_x", "tip_y", "tip_z",
                   "position_error_m", "rotation_error_rad"])
        with path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(header)
            for index, time in enumerate(self.times):
                errors = [("" if np.isnan(e) else f"{e:.9g}")
                          for e in (self.position_errors[index], self.rotation_errors[index])]
                writer.writerow([f"{time:.9f}", *[f"{v:.12g}" for v in self.positions[index]],
                                 *[f"{v:.12g}" for v in self.velocities[index]],
                                 *[f"{v:.12g}" for v in self.accelerations[index]],
                                 *[f"{v:.12g}" for v in self.tip_positions[index]], *errors])
        return path


def make_trajectory(timed: TimedPath, dt: float | None = None, times=None) -> Trajectory:
    """Sample ``timed`` at its knot times (default), every ``dt`` seconds (end included), or at ``times``.

    The achieved tip path is FK of the sampled joints; the tracking error compares it with the
    path's task reference at the same path parameter s(t).
    """
    if times is not None:
        times = np.asarray(times, dtype=float)
    elif dt is not None:
        if not dt > 0:
            raise InvalidConfigurationError(f"dt must be positive, got {dt}")
        times = np.append(np.arange(0.0, timed.duration, dt), timed.duration)
        times = np.unique(times)
    else:
        times = timed.knot_times.copy()
    positions, velocities, accelerations = timed.evaluate(times)
    chain = timed.path.chain
    tips = [chain.fk(q) for q in positions]
    tip_positions = np.array([pose.translation for pose in tips])
    tip_rotations = np.array([pose.rotation for pose in tips])
    if timed.path.reference is not None:
        position_errors, rotation_errors = tracking_errors(chain, timed.path.reference,
                                                           timed.parameter(times), positions)
    else:
        position_errors = rotation_errors = np.full(len(times), np.nan)
    info = {"time_law": timed.law.name, "timing_mode": timed.mode,
            "velocity_limit": timed.velocity_limit.tolist(),
            "acceleration_limit": None if timed.acceleration_limit is None
            else timed.acceleration_limit.tolist(),
            "path": timed.path.summary()}
    return Trajectory(chain.robot.name, chain.name, chain.base_frame, chain.tip_frame,
                      list(chain.joint_names), times, positions, velocities, accelerations,
                      tip_positions, tip_rotations, position_errors, rotation_errors, info)
