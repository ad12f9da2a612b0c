"""Joint limits as bounds on one step dq: position, velocity and acceleration limits, locked joints."""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from functools import partial

import numpy as np
import pinocchio as pin

from wbik.errors import RobotDescriptionError
from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.constraint import (
    SLACK,
    BoundConstraint,
    Measure,
    StartViolation,
    bounded_joint_indices,
    tangent_names,
)
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import BoundRows, RowLabel, StackedRows, as_index

_POSITION_BOUNDS = compiled_twin("qp_rows", "position_bounds")
"""The compiled twin of JointPositionLimits.bounds tightening the step's box (None where it is not built)."""


class RateLimits(BoundConstraint):
    """Bounds on how fast a coordinate may change (``rate``: "velocity", "acceleration"), in words."""

    rate = ""
    per_step = ""
    velocity: np.ndarray | None = None  # (nv) the velocity now, for a constraint that keeps it

    def label_values(self, kinematics: Kinematics, rows: BoundRows) -> tuple[list, list, list, list]:
        now = [np.nan] * len(self.limit) if self.velocity is None else self.velocity[self.v_index].tolist()
        return self.v_index.tolist(), now, (-self.limit).tolist(), self.limit.tolist()

    def row_text(self, label: RowLabel) -> str:
        return f"{self.rate} limit of {label.subject} ({label.side}, {abs(label.bound):.3g} {self.unit})"

    def blocker_text(self, label: RowLabel) -> str:
        return f"the {self.rate} limit of {label.subject} ({abs(label.bound):.3g} {self.unit}{self.per_step})"

    def advice(self, label: RowLabel) -> str:
        return (f"the {self.rate} limit of {label.subject} bounds each step: more iterations "
                "(max_iterations) reach further")


class JointPositionLimits(BoundConstraint):
    """q_min <= q + dq <= q_max on every bounded 1-DOF joint but the continuous ``unbounded`` ones."""

    name = "joint position limits"
    label_kind = "joint limit"
    quantity = "limit excess"
    unit = "rad"

    def __init__(self, unbounded: Collection[str] = ()):
        self.unbounded = tuple(unbounded)

    def _bind(self, model: pin.Model) -> None:
        self.q_index, self.v_index = bounded_joint_indices(model, self.unbounded)
        self.lower = model.lowerPositionLimit[self.q_index].copy()
        self.upper = model.upperPositionLimit[self.q_index].copy()
        self._q_rows, self._v_rows = as_index(self.q_index), as_index(self.v_index)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        q = kinematics.q[self._q_rows]
        return BoundRows(self._v_rows, self.lower - q, self.upper - q)

    def compiled_rows(self, kinematics: Kinematics, rows: StackedRows) -> Callable[[], None] | None:
        """The box tightened by ``bounds`` in one kernel call on the kinematics' own q."""
        kernel = chosen(None, _POSITION_BOUNDS, "qp_rows")
        if kernel is None:
            return None
        self.bind(kinematics.model)
        q_index, v_index = (np.ascontiguousarray(index, dtype=np.int64)
                            for index in (self.q_index, self.v_index))
        return partial(kernel, kinematics.q, q_index, v_index, self.lower, self.upper, rows.lb, rows.ub)

    def label_values(self, kinematics: Kinematics, rows: BoundRows) -> tuple[list, list, list, list]:
        return (self.v_index.tolist(), kinematics.q[self.q_index].tolist(), self.lower.tolist(),
                self.upper.tolist())

    def clip(self, q: np.ndarray) -> None:
        """Clip q (nq) into the limits, in place."""
        if isinstance(rows := self._q_rows, slice):  # a view: clipped in place
            view = q[rows]
            np.maximum(view, self.lower, out=view)
            np.minimum(view, self.upper, out=view)
        else:
            q[rows] = np.minimum(np.maximum(q[rows], self.lower), self.upper)

    def violation(self, kinematics: Kinematics) -> float:
        q = kinematics.q[self._q_rows]
        return float(max((self.lower - q).max(initial=0.0), (q - self.upper).max(initial=0.0)))

    def measure(self, kinematics: Kinematics, tolerances) -> Measure:
        self.bind(kinematics.model)
        excess = self.violation(kinematics)
        return Measure(self.name, self.quantity, excess, "rad", excess <= SLACK,
                       f"a joint {excess:.3g} beyond its limits")

    def start_violations(self, kinematics: Kinematics, q0: np.ndarray) -> list[StartViolation]:
        names, found = tangent_names(kinematics.model), []
        for v, value, low, high in zip(self.v_index.tolist(), q0[self.q_index].tolist(), self.lower.tolist(),
                                       self.upper.tolist(), strict=True):
            for outside, bound, side, sign in ((value > high + SLACK, high, "upper", ">"),
                                               (value < low - SLACK, low, "lower", "<")):
                if outside:
                    text = f"joint {names[v]} at {value:.4g} rad {sign} {bound:.4g}"
                    found.append(self.start_violation(names[v], value, bound, "rad", text, side, True))
        return found

    def row_text(self, label: RowLabel) -> str:
        return f"joint {label.subject} {label.side} limit ({label.bound:.4g} rad; at {label.value:.4g})"

    def blocker_text(self, label: RowLabel) -> str:
        return f"joint {label.subject} at its {label.side} limit ({label.bound:.4g} rad)"

    def advice(self, label: RowLabel) -> str:
        return (f"the goal needs {label.subject} beyond its {label.side} limit: bring the target within the "
                "joints' range")


class JointVelocityLimits(RateLimits):
    """|dq_i| <= v_max,i ``period`` dt (``limit``: nv values, default the model's; ``period``: s)."""

    name = "joint velocity limits"
    label_kind = "velocity limit"
    unit = "rad/s"
    rate, per_step = "velocity", " per step"

    def __init__(self, limit: Sequence[float] | np.ndarray | None = None, period: float = 1.0):
        self._given = None if limit is None else np.asarray(limit, dtype=float)
        self.period = float(period)

    def _bind(self, model: pin.Model) -> None:
        limit = model.velocityLimit.copy() if self._given is None else self._given
        if limit.shape != (model.nv,):
            raise RobotDescriptionError(f"velocity limits need nv = {model.nv} values, got {limit.size}")
        self.v_index = np.flatnonzero(np.isfinite(limit) & (limit > 0) & (limit < 1e10))
        self.limit = limit[self.v_index]

    @property
    def step_limit(self) -> np.ndarray:
        """The bound on one IK step at dt 1 of each limited coordinate: v_max ``period`` (rad or m)."""
        return self.limit * self.period

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        step = self.limit * (self.period * dt)
        return BoundRows(self.v_index, -step, step)


class JointAccelerationLimits(RateLimits):
    """|dq/dt - v_prev| <= a_max dt on the joints with a positive finite acceleration limit, and room to brake
    before a position limit: -dt v_stop(q - q_min) <= dq <= dt v_stop(q_max - q) (:func:`stopping_velocity`).
    ``v_prev`` (``velocity``, nv): the last step's dq / dt, or measured. ``acceleration_limit``: rad/s^2,
    one value (none on a floating base) or nv (inf or 0: none); ``period``: one IK step's time (s)."""

    name = "joint acceleration limits"
    label_kind = "acceleration limit"
    unit = "rad/s^2"
    rate = "acceleration"

    def __init__(self, acceleration_limit: float | np.ndarray, period: float = 1.0,
                 unbounded: Collection[str] = ()):
        given = np.asarray(acceleration_limit, dtype=float)
        if np.any(np.isnan(given)) or np.any(given < 0):
            raise ValueError(f"acceleration limits must be >= 0, got {acceleration_limit!r}")
        self._given, self.period, self.unbounded = given * float(period) ** 2, float(period), tuple(unbounded)
        self.velocity = np.zeros(0)

    def _bind(self, model: pin.Model) -> None:
        limit = self._given
        if limit.ndim == 0:
            limit = np.full(model.nv, float(limit))
            limit[:6 if model.njoints > 1 and model.joints[1].nv == 6 else 0] = np.inf
        if limit.shape != (model.nv,):
            raise ValueError(f"acceleration limits need one value or nv = {model.nv} values, "
                             f"got {limit.size}")
        self.v_index = np.flatnonzero(np.isfinite(limit) & (limit > 0))
        self.limit = limit[self.v_index]
        if self.velocity.shape != (model.nv,):
            self.velocity = np.zeros(model.nv)
        q_index, v_index = bounded_joint_indices(model, self.unbounded)
        selected = np.isin(v_index, self.v_index)
        self._q_braking, self._v_braking = q_index[selected], v_index[selected]
        self._braking_rows = np.searchsorted(self.v_index, self._v_braking)
        self._lower = model.lowerPositionLimit[self._q_braking].copy()
        self._upper = model.upperPositionLimit[self._q_braking].copy()

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        previous = self.velocity[self.v_index]
        change = self.limit * dt
        lower, upper = (previous - change) * dt, (previous + change) * dt
        if self._q_braking.size:
            q = kinematics.q[self._q_braking]
            rows = self._braking_rows
            limit = self.limit[rows]
            upper[rows] = np.minimum(upper[rows], dt * stopping_velocity(self._upper - q, limit, dt))
            lower[rows] = np.maximum(lower[rows], -dt * stopping_velocity(q - self._lower, limit, dt))
        return BoundRows(self.v_index, lower, upper)

    def stepped(self, dq: np.ndarray, dt: float) -> None:
        self.velocity = np.asarray(dq, dtype=float) / dt


def stopping_velocity(distance: np.ndarray, acceleration: np.ndarray, dt: float) -> np.ndarray:
    """The largest v >= 0 with D(v) = dt sum_k max(v - k a dt, 0) <= distance (0 for distance <= 0).

    D is piecewise linear: on [n a dt, (n + 1) a dt), D(v) = dt ((n + 1) v - a dt n (n + 1) / 2), and
    D(n a dt) = a dt^2 n (n + 1) / 2, so n = floor((sqrt(1 + 8 d / (a dt^2)) - 1) / 2) and
    v = min((d / dt + a dt n (n + 1) / 2) / (n + 1), (n + 1) a dt)."""
    distance = np.maximum(np.asarray(distance, dtype=float), 0.0)
    step = acceleration * dt
    n = np.floor((np.sqrt(1.0 + 8.0 * distance / (step * dt)) - 1.0) / 2.0)
    return np.minimum((distance / dt + 0.5 * step * n * (n + 1.0)) / (n + 1.0), (n + 1.0) * step)


class LockedJoints(BoundConstraint):
    """Named joints keep their value: 0 <= dq_i <= 0 (e.g. the arms alone, without the lift)."""

    label_kind = "locked joint"

    def __init__(self, joints: Sequence[str]):
        self.joints = list(joints)
        self.name = f"locked joints {', '.join(self.joints)}"

    def _bind(self, model: pin.Model) -> None:
        indices = []
        for name in self.joints:
            if not model.existJointName(name):
                raise RobotDescriptionError(f"cannot lock joint {name!r}: the model has no such joint")
            joint = model.joints[model.getJointId(name)]
            indices.extend(range(joint.idx_v, joint.idx_v + joint.nv))
        self.v_index = np.array(indices, dtype=int)

    def bounds(self, kinematics: Kinematics, dt: float) -> BoundRows:
        return BoundRows(self.v_index, 0.0, 0.0)

    def row_text(self, label: RowLabel) -> str:
        return f"locked joint {label.subject}"

    blocker_text = row_text

    def conflict_advice(self, labels: list[RowLabel]) -> str:
        return "unlock a joint the conflicting rows need, or drop one of the conflicting constraints"
