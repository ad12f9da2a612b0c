"""What a walk is judged by on the full model, from its configurations alone: multibody ZMP margin,
CoM error, foot slip, swing clearance, joint limits and peaks, leg distance, distance and speed."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbik.motion.walking.footsteps import Feet, centre_frame, sole_points, yaw_of
from wbik.motion.walking.multibody_zmp import (
    actuated_joints,
    limit_excess,
    multibody_zmp,
    trajectory_derivatives,
)
from wbik.qp.support_polygon import support_region
from wbik.robot import Robot


def _stretches(flags: list[bool]) -> list[tuple[int, int]]:
    """(first, last) index of every run of True."""
    edges = np.diff(np.r_[0, np.asarray(flags, dtype=int), 0])
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, strict=True))


def walk_figures(robot: Robot, feet: Feet, times: np.ndarray, qs: np.ndarray, support: list[tuple[str, ...]],
                 ground_z: float = 0.0, margin: float = 0.0, com_reference: np.ndarray | None = None,
                 collision_model=None) -> tuple[dict, dict]:
    """(figures, series) of ``qs`` at ``times``, soles ``support`` down: figures JSON-friendly (SI, margin
    positive inside, -inf without a ZMP), series ``zmp`` (K, 3) and ``zmp_margin`` (K,)."""
    model, data = robot.model, robot.model.createData()
    times, qs = np.asarray(times, dtype=float), np.asarray(qs, dtype=float)
    velocity, acceleration = trajectory_derivatives(model, qs, float(np.median(np.diff(times))))
    zmp = multibody_zmp(model, qs, velocity, acceleration, ground_z, data)
    frames = {frame: model.getFrameId(frame) for frame in feet.frames}
    placements = {frame: [] for frame in feet.frames}
    com, margins = np.zeros((len(qs), 3)), np.zeros(len(qs))
    lowest = {frame: np.zeros(len(qs)) for frame in feet.frames}
    regions: dict[tuple, object] = {}  # support polygons by soles and their placements (to 1 um)
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        com[k] = pin.centerOfMass(model, data, q, False)
        points, key = [], []
        for frame, frame_id in frames.items():
            placement = data.oMf[frame_id].copy()
            placements[frame].append(placement)
            corners = sole_points(robot, frame, placement)
            lowest[frame][k] = float(corners[:, 2].min()) - ground_z
            if frame in support[k]:
                points.append(corners[:, :2])
                key.append((frame, *np.round(corners[:, :2], 6).ravel().tolist()))
        key = tuple(key)
        if points and key not in regions:
            regions[key] = support_region(np.vstack(points))
        region = regions.get(key)
        finite = bool(np.all(np.isfinite(zmp[k])))
        margins[k] = region.margin_of(zmp[k]) if (region is not None and finite) else -math.inf
    finite_margins = margins[np.isfinite(margins)]
    worst = int(np.argmin(margins))
    figures = {
        "samples": len(qs), "duration_s": float(times[-1] - times[0]),
        "zmp_margin_min_m": float(margins.min()),
        "zmp_margin_min_at_s": float(times[worst] - times[0]),
        "zmp_margin_min_support": list(support[worst]),
        "zmp_margin_p5_m": float(np.percentile(margins, 5, method="lower")),
        "zmp_margin_median_m": float(np.median(finite_margins)) if finite_margins.size else None,
        "samples_zmp_under_margin": int(np.sum(margins < margin)),
        "samples_without_zmp": int(np.sum(~np.all(np.isfinite(zmp), axis=1))),
    }
    if com_reference is not None:
        error = np.linalg.norm(com - np.asarray(com_reference, dtype=float), axis=1)
        figures["com_error_max_m"] = float(error.max())
        figures["com_error_rms_m"] = float(np.sqrt(np.mean(error ** 2)))
    slip, slip_rad, swing_peaks, swing_low = 0.0, 0.0, [], math.inf
    for frame in feet.frames:
        down = [frame in s for s in support]
        for first, last in _stretches(down):
            held = placements[frame][first]
            for k in range(first + 1, last + 1):
                moved = placements[frame][k]
                slip = max(slip, float(np.linalg.norm(moved.translation - held.translation)))
                slip_rad = max(slip_rad, float(np.linalg.norm(pin.log3(held.rotation.T @ moved.rotation))))
        for first, last in _stretches([not d for d in down]):
            heights = lowest[frame][first:last + 1]
            swing_peaks.append(float(heights.max()))
            swing_low = min(swing_low, float(heights.min()))
    figures.update({"foot_slip_max_m": slip, "foot_slip_max_rad": slip_rad,
                    "swings": len(swing_peaks),
                    "swing_clearance_min_m": min(swing_peaks) if swing_peaks else None,
                    "swing_height_min_m": swing_low if swing_peaks else None})
    joint_ids = actuated_joints(model)
    actuated = np.array([model.joints[j].idx_v for j in joint_ids])
    speeds = np.abs(velocity[:, actuated])
    accelerations = np.abs(acceleration[:, actuated])
    limit = model.velocityLimit[actuated]
    finite_limit = np.where(np.isfinite(limit) & (limit > 0) & (limit < 1e10), limit, np.inf)
    names = [model.names[j] for j in joint_ids]
    peak_joint = int(np.argmax(speeds.max(axis=0)))
    figures.update({
        "joint_limit_excess_max_rad": limit_excess(model, qs),
        "joint_velocity_peak_rad_s": float(speeds.max()),
        "joint_velocity_peak_joint": names[peak_joint],
        "joint_velocity_over_limit": float(np.max(speeds / finite_limit)),
        "joint_acceleration_peak_rad_s2": float(accelerations.max()),
        "joint_acceleration_p95_rad_s2": float(np.percentile(accelerations.max(axis=1), 95)),
        "joint_acceleration_peak_joint": names[int(np.argmax(accelerations.max(axis=0)))],
    })
    if collision_model is not None and collision_model.pairs:
        figures["leg_distance_min_m"] = float(min(collision_model.minimum(q).distance for q in qs))
    first = centre_frame(placements[feet.left][0], placements[feet.right][0])
    last = centre_frame(placements[feet.left][-1], placements[feet.right][-1])
    distance = float(np.linalg.norm((last.translation - first.translation)[:2]))
    figures.update({"distance_m": distance,
                    "turn_deg": math.degrees(math.remainder(yaw_of(last.rotation) - yaw_of(first.rotation),
                                                            2 * math.pi)),
                    "speed_m_s": distance / figures["duration_s"] if figures["duration_s"] > 0 else 0.0})
    series = {"zmp": np.column_stack([zmp, np.full(len(zmp), ground_z)]), "zmp_margin": margins}
    return figures, series

