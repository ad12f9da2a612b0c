"""Path following by continuation: sub-points P_a + (k / substeps) (P_b - P_a), rotations
R_a exp(k / substeps log(R_a^T R_b)), each solved from the last good joints (failures recorded)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.geometry import rotation_error
from wbik.solvers.base import Solver
from wbik.solvers.result import IKResult
from wbik.targets import Target, as_target


@dataclass
class PathResult:
    """Joint rows of the whole path (the start first) and the result at every waypoint."""

    joints: np.ndarray  # (rows, n): q0, then one row per solved sub-point
    waypoint_results: list[IKResult]
    failures: list[str] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return all(result.success for result in self.waypoint_results) and not self.failures

    @property
    def reached(self) -> list[bool]:
        return [result.success for result in self.waypoint_results]


def interpolate(start: Target, end: Target, fraction: float) -> Target:
    """The point ``fraction`` of the way from start to end (straight line, geodesic rotation)."""
    position = start.position + fraction * (end.position - start.position)
    if end.rotation is None:
        return Target(position)
    start_rotation = end.rotation if start.rotation is None else start.rotation
    step = rotation_error(end.rotation, start_rotation)  # log3(R_a^T R_b): the end seen from the start
    return Target(position, start_rotation @ pin.exp3(fraction * step))


def follow_path(solver: Solver, waypoints: Sequence, q0: Sequence[float] | None = None,
                substeps: int = 10) -> PathResult:
    """Solve every sub-point of the path through ``waypoints`` from ``q0`` (default: nominal)."""
    if substeps < 1:
        raise InvalidConfigurationError(f"substeps must be at least 1, got {substeps}")
    chain = solver.chain
    q = chain.nominal.copy() if q0 is None else chain.check_q(q0)
    targets = [as_target(waypoint) for waypoint in waypoints]
    reached = chain.fk(q)
    current = Target(reached.translation.copy(), reached.rotation.copy())
    rows, results, failures = [q.copy()], [], []
    for index, waypoint in enumerate(targets):
        start = current if waypoint.is_pose else Target(current.position)
        result = None
        for k in range(1, substeps + 1):
            sub_target = waypoint if k == substeps else interpolate(start, waypoint, k / substeps)
            result = solver.solve(sub_target, q)
            if result.q is not None and result.success:
                q = result.q
                rows.append(q.copy())
            elif k < substeps:
                failures.append(f"waypoint {index + 1}, sub-point {k}/{substeps}: {result.reason}")
        if not result.success:
            failures.append(f"waypoint {index + 1} {waypoint.position.tolist()} not reached: {result.reason}")
        results.append(result)
        current = waypoint if result.success else Target(chain.fk(q).translation, chain.fk(q).rotation)
    return PathResult(np.array(rows), results, failures)
