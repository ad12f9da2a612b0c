"""PhantomX Pincher moves of the seed's teleoperation (pincher.md): joint jog, straight TCP lines in the
working plane (our reading of the seed: the TCP at shoulder height, the tool horizontal pointing away from
the base axis) and the automatic mode's path."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.motion.cartesian import DEFAULT_JUMP_THRESHOLD, follow
from wbik.motion.joint import joint_path
from wbik.motion.path import JointPath
from wbik.robot import Chain
from wbik.solvers.base import Solver
from wbik.targets import Target

PLANE_HEIGHT = 0.137  # m, shoulder height d1
PLANE_REACH = 0.105 + 0.105 + 0.095  # m, arm stretched flat
PLANE_MIN_RADIUS = 0.095 + 2 * 0.105 * math.cos(math.radians(75.0))  # m, elbow folded to 150 deg
PLANE_SECTOR = math.radians(150.0)  # rad, |base angle| limit
# the automatic mode's pick-and-place cycle (ours: the seed gives none), (x, y, z, tool pitch) points
AUTOMATIC_CYCLE = (
    (0.15, 0.0, 0.12, -math.pi / 2),
    *((0.15 * math.cos(angle), 0.15 * math.sin(angle), z, -math.pi / 2)
      for angle in (-0.698, 0.698) for z in (0.10, 0.04, 0.10)),
    (0.15, 0.0, 0.12, -math.pi / 2),
)
HOME_SEED = np.array([0.0, 0.5, 1.2, 1.44])  # elbow up: the joints the cycle's home is solved from


def tool_rotation(chain: Chain, yaw: float, pitch: float) -> np.ndarray:
    """Rotation of 'noa' for base angle ``yaw`` and tool pitch above the horizontal (rad), q2 + q3 + q4
    = pi/2 - pitch."""
    return chain.fk(np.array([yaw, math.pi / 2, 0.0, -pitch])).rotation.copy()


def jog(chain: Chain, q: Sequence[float], joint: int | str, delta: float, samples: int = 10) -> JointPath:
    """Move one joint by ``delta`` (rad) from q, stopped by its limit (``info['clipped']``)."""
    q = chain.check_q(q)
    index = chain.joint_names.index(joint) if isinstance(joint, str) else int(joint)
    if not 0 <= index < chain.nq:
        raise InvalidConfigurationError(f"joint index {index} is not in 0..{chain.nq - 1}")
    goal = q.copy()
    goal[index] = np.clip(q[index] + delta, chain.lower[index], chain.upper[index])
    path = joint_path(chain, [q, goal], samples)
    moved = goal[index] - q[index]
    path.info.update({"kind": "jog", "joint": chain.joint_names[index], "requested": float(delta),
                      "moved": float(moved), "clipped": not math.isclose(moved, delta, abs_tol=1e-12)})
    return path


class ToolPathReference:
    """Straight segments through (x, y, z, pitch) points, equal shares of s, the yaw atan2(y, x): poses a
    4-DOF Pincher can take."""

    def __init__(self, chain: Chain, points: Sequence[Sequence[float]]):
        self.chain = chain
        self.points = np.asarray(points, dtype=float)
        if self.points.ndim != 2 or self.points.shape[1] != 4 or len(self.points) < 2:
            raise InvalidConfigurationError("give at least two (x, y, z, pitch) points")
        self.segments = len(self.points) - 1

    def point(self, s: float) -> np.ndarray:
        scaled = min(max(float(s), 0.0), 1.0) * self.segments
        index = min(int(math.floor(scaled)), self.segments - 1)
        start, end = self.points[index], self.points[index + 1]
        return start + (scaled - index) * (end - start)

    def target(self, s: float) -> Target:
        x, y, z, pitch = self.point(s)
        return Target(np.array([x, y, z]), tool_rotation(self.chain, math.atan2(y, x), pitch))


def plane_reason(xy: Sequence[float]) -> str:
    """Why (x, y) is outside the working plane's reachable band, or '' when it is inside."""
    radius, angle = math.hypot(xy[0], xy[1]), math.atan2(xy[1], xy[0])
    if radius > PLANE_REACH + 1e-12:
        return f"radius {radius * 1e3:.1f} mm beyond the {PLANE_REACH * 1e3:.0f} mm reach"
    if radius < PLANE_MIN_RADIUS - 1e-12:
        return f"radius {radius * 1e3:.1f} mm inside the {PLANE_MIN_RADIUS * 1e3:.1f} mm the folded arm needs"
    if abs(angle) > PLANE_SECTOR + 1e-12:
        return f"base angle {math.degrees(angle):.1f} deg outside +-150 deg"
    return ""


def tool_path(solver: Solver, points: Sequence[Sequence[float]], samples: int = 10,
              q0: Sequence[float] | None = None, jump_threshold: float = DEFAULT_JUMP_THRESHOLD) -> JointPath:
    """Straight TCP segments through (x, y, z, pitch) points, ``samples`` each, from ``q0``."""
    reference = ToolPathReference(solver.chain, points)
    x, y = reference.points[0, :2]
    elbow_up = np.array([math.atan2(y, x), 0.3 + math.pi / 2, -0.6, 0.3])
    q0 = solver.chain.check_q(elbow_up if q0 is None else q0)
    first = solver.solve(reference.target(0.0), q0)
    q_start = first.q if first.q is not None else q0
    count = reference.segments * samples
    path = follow(solver, reference, np.arange(count + 1) / count, q_start, jump_threshold,
                  waypoint_s=[(k + 1) / reference.segments for k in range(reference.segments)])
    if not first.success:
        path.solved[0] = False
        path.reasons[0] = f"start: {first.reason}"
    path.info.update({"kind": "pincher_tool_path", "samples_per_segment": samples})
    return path


def plane_line(solver: Solver, start_xy: Sequence[float], goal_xy: Sequence[float], samples: int = 20,
               q0: Sequence[float] | None = None,
               jump_threshold: float = DEFAULT_JUMP_THRESHOLD) -> JointPath:
    """Straight TCP line in the working plane (m); samples outside it in ``info['outside_plane']``."""
    start, goal = np.asarray(start_xy, dtype=float), np.asarray(goal_xy, dtype=float)
    points = [(*start, PLANE_HEIGHT, 0.0), (*goal, PLANE_HEIGHT, 0.0)]
    path = tool_path(solver, points, samples, q0, jump_threshold)
    outside = {int(k): reason for k, s in enumerate(path.s)
               if (reason := plane_reason(start + s * (goal - start)))}
    path.info.update({"kind": "pincher_plane_line", "start_xy_m": start.tolist(), "goal_xy_m": goal.tolist(),
                      "outside_plane": outside})
    return path


def automatic_path(solver: Solver, samples: int = 10) -> JointPath:
    """The automatic mode: the fixed cycle AUTOMATIC_CYCLE as straight TCP segments."""
    path = tool_path(solver, AUTOMATIC_CYCLE, samples, HOME_SEED)
    path.info["kind"] = "pincher_automatic"
    return path
