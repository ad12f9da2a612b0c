"""Distances kept: between two frame origins, and between collision shapes (coal)."""

from __future__ import annotations

import numpy as np

from wbik.errors import InvalidSettingError, RobotDescriptionError
from wbik.qp.constraint import SLACK, InequalityConstraint, Measure, StartViolation
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import InequalityRows, RowLabel
from wbik.schema import Number


class MinimumDistance(InequalityConstraint):
    """|p_a - p_b| >= distance between two frame origins, linearised along u = (p_a - p_b)/|p_a - p_b|:
    -u^T (J_v,a - J_v,b) dq <= |p_a - p_b| - distance."""

    label_kind = "distance"
    quantity = "clearance"

    def __init__(self, frame_a: str, frame_b: str, distance: float):
        self.frames = (frame_a, frame_b)
        self.distance = float(distance)
        self.name = f"distance({frame_a}, {frame_b}) >= {distance:g} m"
        self.ids = (-1, -1)

    def start(self, kinematics: Kinematics) -> None:
        self.ids = (kinematics.frame_id(self.frames[0]), kinematics.frame_id(self.frames[1]))

    def current_distance(self, kinematics: Kinematics) -> tuple[float, np.ndarray]:
        offset = (kinematics.placement(self.ids[0]).translation
                  - kinematics.placement(self.ids[1]).translation)
        return float(np.linalg.norm(offset)), offset

    def labels(self, kinematics: Kinematics, rows) -> list[RowLabel]:
        return [self.label(f"{self.frames[0]}-{self.frames[1]}", "", self.current_distance(kinematics)[0],
                           self.distance, "m")]

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        distance, offset = self.current_distance(kinematics)
        direction = offset / max(distance, 1e-12)
        relative = kinematics.jacobian(self.ids[0])[:3] - kinematics.jacobian(self.ids[1])[:3]
        return InequalityRows(-(direction @ relative)[None, :], np.array([distance - self.distance]))

    def violation(self, kinematics: Kinematics) -> float:
        return max(self.distance - self.current_distance(kinematics)[0], 0.0)

    def measure(self, kinematics: Kinematics, tolerances) -> Measure:
        self.start(kinematics)
        clearance = self.current_distance(kinematics)[0] - self.distance
        return Measure(self.name, self.quantity, clearance, "m", clearance >= -SLACK,
                       f"a minimum distance broken by {-clearance:.3g} m")

    def row_text(self, label: RowLabel) -> str:
        return f"distance {label.subject} {label.value:.4g} m (at least {label.bound:g} m)"

    def blocker_text(self, label: RowLabel) -> str:
        return f"minimum distance {label.subject} ({label.value:.4g} m, at least {label.bound:g} m)"

    def advice(self, label: RowLabel) -> str:
        return f"{label.subject} is at its safety distance: the goal is behind it"


class CollisionAvoidance(InequalityConstraint):
    """Each pair of a :class:`wbik.collision.CollisionModel` nearer than ``influence_distance`` (m), with
    coal's distance d and normal n (a -> b): n^T (J_a - J_b) dq <= gain (d - safety - padding), the velocity
    damper of Pink / mink / PlaCo (``safety_distance``, ``padding``: m)."""

    label_kind = "collision"
    quantity = "clearance"

    def __init__(self, pairs, safety_distance: float = 0.01, influence_distance: float = 0.1,
                 gain: float = 1.0, padding: float = 1e-6):
        self.collision_model = pairs
        self.safety = Number(ge=0, unit="m", as_float=True).checked(safety_distance, "safety_distance",
                                                                    "CollisionAvoidance")
        positive = Number(gt=0, unit="m", as_float=True)
        self.influence = positive.checked(influence_distance, "influence_distance", "CollisionAvoidance")
        if self.influence <= self.safety:
            raise InvalidSettingError(f"influence_distance ({self.influence:g} m) must exceed the safety "
                                      f"distance ({self.safety:g} m)")
        self.gain = Number(gt=0, le=1, as_float=True).checked(gain, "gain", "CollisionAvoidance")
        self.padding = float(padding)
        self.name = f"collision avoidance (safety {self.safety * 1e3:g} mm)"
        self.geometry_data = pairs.create_data()
        self._distances = []
        self._q = None

    def start(self, kinematics: Kinematics) -> None:
        model = self.collision_model.model
        if kinematics.model.nq != model.nq or kinematics.model.nv != model.nv:
            raise RobotDescriptionError(f"the collision model was built on another robot model (nq "
                                        f"{model.nq}, problem nq {kinematics.model.nq})")
        self._q = None

    def distances(self, kinematics: Kinematics) -> list:
        """Pair distances at the kinematics' q (computed once per configuration)."""
        if self._q is None or not np.array_equal(self._q, kinematics.q):
            self._distances = self.collision_model.compute(kinematics.data, self.geometry_data)
            self._q = kinematics.q.copy()
        return self._distances

    def minimum(self, kinematics: Kinematics):
        """The closest pair (a wbik.collision.PairDistance) at the current q, or None."""
        return min(self.distances(kinematics), key=lambda d: d.distance, default=None)

    def labels(self, kinematics: Kinematics, rows) -> list[RowLabel]:
        if not (near := [pair for pair in self.distances(kinematics) if pair.distance < self.influence]):
            return [self.label("no pair within the influence distance")]
        return [self.label(f"{pair.a}-{pair.b}", "", float(pair.distance), self.safety, "m") for pair in near]

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        rows, bounds = [], []
        target = self.safety + self.padding
        for pair in self.distances(kinematics):
            if pair.distance >= self.influence:
                continue
            rows.append(-self.collision_model.distance_gradient(kinematics.data, pair))
            bounds.append(self.gain * (pair.distance - target))
        return (InequalityRows(np.array(rows), np.array(bounds)) if rows
                else InequalityRows(np.zeros((1, kinematics.nv)), np.ones(1)))  # (none near: one that holds)

    def violation(self, kinematics: Kinematics) -> float:
        closest = self.minimum(kinematics)
        return 0.0 if closest is None else max(self.safety - closest.distance, 0.0)

    def measure(self, kinematics: Kinematics, tolerances) -> Measure:
        closest = self.minimum(kinematics)
        clearance = np.inf if closest is None else closest.distance - self.safety
        return Measure(self.name, self.quantity, clearance, "m", clearance >= -SLACK,
                       f"a collision pair {clearance * -1e3:.3g} mm inside its safety distance")

    def start_violations(self, kinematics: Kinematics, q0: np.ndarray) -> list[StartViolation]:
        if self.violation(kinematics) <= SLACK:
            return []
        closest = self.minimum(kinematics)
        pair = f"{closest.a}-{closest.b}"
        return [self.start_violation(pair, closest.distance, self.safety, "m",
                                     f"collision pair {pair} at {closest.distance * 1e3:.3g} mm < safety "
                                     f"{self.safety * 1e3:g} mm")]

    def row_text(self, label: RowLabel) -> str:
        return (f"collision pair {label.subject} at {label.value * 1e3:.3g} mm "
                f"(safety {label.bound * 1e3:g} mm)")

    blocker_text = row_text
    advice = MinimumDistance.advice
