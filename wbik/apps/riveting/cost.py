"""A deterministic cost model of planning time, so that planning can be charged to the 300 s run.

Measured wall time depends on the machine's load, so the run charges planning by counting the
planner's elementary operations and multiplying each count by a calibrated unit cost (s). The wall
time is measured too and reported beside it, never charged.

Operations counted (each through the planner's own calls, see :class:`CountingCollision`):

- ``ik``: one closed-form UR5 solve (all 8 branches, or the one nearest a seed);
- ``clearance``: one coal distance query of the whole robot against workpiece and table;
- ``line_timing``: the closed-form minimum-time scaling of a two-knot joint line;
- ``line_estimate``: the closed-form minimum time of a two-knot line (a few numpy operations);
- ``spline_timing``: the numerical minimum-time scaling of a multi-knot spline;
- ``grid_points``: one point of the fine time grid on which a route's joint motion is bounded
  between its checked samples (spline evaluation, position and velocity);
- ``qp_iteration``: one QP step (its clearance queries are counted separately).

UNIT_COST_S: the medians :func:`calibrate` measures on the reference machine, rounded up;
``line_estimate`` and ``qp_iteration`` are estimates, not measured (the QP fallback is not used on the
default cell). The model leaves out the Python work between operations, so it charges somewhat less
than the wall time. The figures: docs/measurements.md, riveting cost; ``python -m
wbik.apps.riveting.cost`` prints the current machine's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from dataclasses import field

import numpy as np

UNIT_COST_S = {
    "ik": 7.0e-4,
    "clearance": 6.0e-4,
    "line_timing": 1.0e-3,
    "line_estimate": 2.0e-5,
    "spline_timing": 3.0e-2,
    "grid_points": 2.0e-6,
    "qp_iteration": 2.0e-3,
}
"""Calibrated cost (s) of one operation of each kind (see the module notes)."""


@dataclass
class PlanningCost:
    """Operation counts of one plan and their charged time under ``UNIT_COST_S``."""

    counts: dict[str, int] = field(default_factory=dict)

    def add(self, kind: str, count: int = 1) -> None:
        if kind not in UNIT_COST_S:
            from wbik.errors import InvalidSettingError

            raise InvalidSettingError(f"unknown planning operation {kind!r}; known: {sorted(UNIT_COST_S)}")
        self.counts[kind] = self.counts.get(kind, 0) + int(count)

    @property
    def seconds(self) -> float:
        return float(sum(UNIT_COST_S[kind] * count for kind, count in self.counts.items()))


class CountingCollision:
    """A CollisionModel whose ``clearance`` calls are counted into ``cost`` (all else delegated)."""

    def __init__(self, collision, cost: PlanningCost | None = None):
        self._collision = collision
        self.cost = cost or PlanningCost()

    def clearance(self, *args, **kwargs):
        self.cost.add("clearance")
        return self._collision.clearance(*args, **kwargs)

    def __getattr__(self, name):
        return getattr(self._collision, name)


def calibrate(repeats: int = 200) -> dict[str, float]:
    """Median wall time (s) of each operation on this machine, in the default riveting cell."""
    import pinocchio as pin

    from wbik.apps.riveting.collision import CollisionModel
    from wbik.apps.riveting.moves import Limits
    from wbik.apps.riveting.moves import sample_times
    from wbik.apps.riveting.moves import timed_move
    from wbik.apps.riveting.plan import Insertion
    from wbik.apps.riveting.scene import build_scene
    from wbik.models import load
    from wbik.solvers.method_registry import solver

    robot = load("ur5")
    scene = build_scene()
    collision = CollisionModel(robot, scene)
    chain = robot.chain("arm")
    limits = Limits(chain.velocity_limit, 5.0)
    analytic = solver("analytic", robot, chain="arm")
    q_home = analytic.solve(scene.rivet_home, robot.nominal).q
    pose = Insertion().approach_pose(scene.hole("h14"))
    q_near = analytic.solve(pin.SE3(pose.rotation, pose.translation), q_home).q

    def median(function, count=repeats):
        values = []
        for _ in range(count):
            started = time.perf_counter()
            function()
            values.append(time.perf_counter() - started)
        return float(np.median(values))

    via = 0.5 * (q_home + q_near) + 0.2
    line = timed_move("line", chain, np.array([q_home, q_near]), limits)
    samples = len(sample_times(line, chain))
    return {
        "ik": median(lambda: analytic.solve_all(pose)),
        "clearance": median(lambda: collision.clearance(q_near)),
        "line_timing": median(lambda: timed_move("x", chain, np.array([q_home, q_near]), limits)),
        "spline_timing": median(lambda: timed_move("x", chain, np.array([q_home, via, q_near]), limits), 20),
        "path_samples": median(lambda: sample_times(line, chain), 20) / max(line.duration / 5e-4, 1.0),
        "samples_per_line": samples,
    }


if __name__ == "__main__":
    for key, value in calibrate().items():
        print(f"{key:14s} {value:.3g}")
