"""A deterministic cost model of planning time, charged to the 300 s run: a plan's counted operations times
calibrated unit costs ``UNIT_COST_S`` (s; docs/measurements.md, riveting cost). ``python -m
wbik.apps.riveting.cost`` prints this machine's."""

from __future__ import annotations

import timeit
from dataclasses import dataclass, field

import numpy as np

from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.moves import Limits, samples, timed_move
from wbik.apps.riveting.plan import Insertion
from wbik.apps.riveting.scene import build_scene
from wbik.errors import InvalidSettingError
from wbik.models import load
from wbik.solvers.method_registry import solver

UNIT_COST_S = {
    "ik": 7.0e-4,
    "clearance": 6.0e-4,
    "line_timing": 1.0e-3,
    "line_estimate": 2.0e-5,
    "spline_timing": 3.0e-2,
    "grid_points": 2.0e-6,
    "qp_iteration": 2.0e-3,
}


@dataclass
class PlanningCost:
    """Operation counts of one plan and their charged time under ``UNIT_COST_S``."""

    counts: dict[str, int] = field(default_factory=dict)

    def add(self, kind: str, count: int = 1) -> None:
        if kind not in UNIT_COST_S:
            raise InvalidSettingError(f"unknown planning operation {kind!r}; known: {sorted(UNIT_COST_S)}")
        self.counts[kind] = self.counts.get(kind, 0) + int(count)

    @property
    def seconds(self) -> float:
        return float(sum(UNIT_COST_S[kind] * count for kind, count in self.counts.items()))


class CountingCollision:
    """A CollisionModel's ``clearance``, its calls counted into ``cost``."""

    def __init__(self, collision, cost: PlanningCost):
        self._collision, self.cost = collision, cost

    def clearance(self, *args, **kwargs):
        self.cost.add("clearance")
        return self._collision.clearance(*args, **kwargs)


def calibrate(repeats: int = 200) -> dict[str, float]:
    """Median wall time (s) of each operation on this machine, in the default riveting cell."""
    robot, scene = load("ur5"), build_scene()
    collision, chain = CollisionModel(robot, scene), robot.chain("arm")
    limits = Limits(chain.velocity_limit, 5.0)
    analytic = solver("analytic", robot, chain="arm")
    pose = Insertion().approach_pose(scene.hole("h14"))
    q_home = analytic.solve(scene.rivet_home, robot.nominal).q
    q_near = analytic.solve(pose, q_home).q

    def median(function, count=repeats):
        return float(np.median(timeit.repeat(function, number=1, repeat=count)))

    via = 0.5 * (q_home + q_near) + 0.2
    line = timed_move("line", chain, np.array([q_home, q_near]), limits)
    return {
        "ik": median(lambda: analytic.solve_all(pose)),
        "clearance": median(lambda: collision.clearance(q_near).minimum("cell")),
        "line_timing": median(lambda: timed_move("x", chain, np.array([q_home, q_near]), limits)),
        "spline_timing": median(lambda: timed_move("x", chain, np.array([q_home, via, q_near]), limits), 20),
        "path_samples": median(lambda: samples(line, chain), 20) / max(line.duration / 5e-4, 1.0),
        "samples_per_line": len(samples(line, chain)[0]),
    }


if __name__ == "__main__":
    for key, value in calibrate().items():
        print(f"{key:14s} {value:.3g}")
