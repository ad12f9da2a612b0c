"""Straight-line and waypoint Cartesian paths solved by continuation; a step max_j |dq_j| above
``jump_threshold`` (rad or m) halves the interval up to ``refinements`` times, else is a reported jump."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wbik.errors import InvalidConfigurationError, InvalidTargetError
from wbik.motion.path import JointPath, TaskReference
from wbik.solvers.base import Solver
from wbik.solvers.path import interpolate
from wbik.solvers.result import IKResult
from wbik.targets import Target, as_target

DEFAULT_JUMP_THRESHOLD = 0.5  # rad or m: the largest joint change between two knots


class PolylineReference:
    """Straight segments through ``points`` (Targets); each segment takes an equal share of s."""

    def __init__(self, points: Sequence[Target]):
        if len(points) < 2:
            raise InvalidTargetError("a Cartesian path needs a start and at least one more point")
        self.points = list(points)
        self.segments = len(self.points) - 1

    def target(self, s: float) -> Target:
        scaled = min(max(float(s), 0.0), 1.0) * self.segments
        index = min(int(np.floor(scaled)), self.segments - 1)
        fraction = scaled - index
        start, end = self.points[index], self.points[index + 1]
        if fraction >= 1.0:
            return end
        return interpolate(start if end.is_pose else Target(start.position), end, fraction)


class FunctionReference:
    """A reference given by a function s -> Target (e.g. a rotation that depends on the position)."""

    def __init__(self, function):
        self.function = function

    def target(self, s: float) -> Target:
        return as_target(self.function(float(s)))


def _step(q_a: np.ndarray, q_b: np.ndarray) -> float:
    return float(np.max(np.abs(q_b - q_a)))


def _advance(solver: Solver, reference: TaskReference, s_from: float, q_from: np.ndarray, s_to: float,
             threshold: float, refinements: int) -> list[tuple[float, IKResult]]:
    """Knots from s_from (excluded) to s_to (included), halving the interval on a jump or a miss."""
    direct = solver.solve(reference.target(s_to), q_from)
    if direct.success and _step(q_from, direct.q) <= threshold or refinements == 0:
        return [(s_to, direct)]
    middle = 0.5 * (s_from + s_to)
    first = _advance(solver, reference, s_from, q_from, middle, threshold, refinements - 1)
    q_middle = first[-1][1].q if first[-1][1].q is not None else q_from
    second = _advance(solver, reference, middle, q_middle, s_to, threshold, refinements - 1)
    refined = first + second
    qs = [q_from, *(result.q for _, result in refined)]
    clean = all(result.success for _, result in refined) and all(
        _step(a, b) <= threshold for a, b in zip(qs[:-1], qs[1:], strict=True))
    return refined if clean or (not direct.success and refined[-1][1].success) else [(s_to, direct)]


def follow(solver: Solver, reference: TaskReference, s_values: Sequence[float], q0: Sequence[float],
           jump_threshold: float = DEFAULT_JUMP_THRESHOLD, refinements: int = 3,
           waypoint_s: Sequence[float] = ()) -> JointPath:
    """Solve ``reference`` at each s (increasing, first = 0 where q0 is the start) by continuation."""
    chain = solver.chain
    q = chain.check_q(q0)
    s_values = np.asarray(s_values, dtype=float)
    if s_values.ndim != 1 or s_values.size < 2 or np.any(np.diff(s_values) <= 0):
        raise InvalidConfigurationError("s values must be an increasing sequence of at least two numbers")
    if jump_threshold <= 0:
        raise InvalidConfigurationError(f"jump_threshold must be positive, got {jump_threshold}")
    first = solver.solve(reference.target(float(s_values[0])), q)
    knots_s, knots_q, solved, reasons, jumps = [float(s_values[0])], [q.copy()], [bool(first.success)], {}, []
    if not first.success:
        reasons[0] = f"start pose: {first.reason}"
    for s_to in s_values[1:]:
        for s_knot, result in _advance(solver, reference, knots_s[-1], q, float(s_to), jump_threshold,
                                       refinements):
            new_q = result.q if result.q is not None else q
            index = len(knots_s)
            notes = [] if result.success else [result.reason or "not reached"]
            if _step(q, new_q) > jump_threshold:
                jumps.append(index)
                notes.insert(0, f"branch jump: a joint moved {_step(q, new_q):.3g} "
                                f"(threshold {jump_threshold:g})")
            if notes:
                reasons[index] = "; ".join(notes)
            knots_s.append(s_knot)
            knots_q.append(new_q.copy())
            solved.append(bool(result.success))
            q = new_q
    knots = np.array(knots_s)
    waypoint_knots = [int(np.argmin(np.abs(knots - s))) for s in waypoint_s]
    return JointPath(chain, knots, np.array(knots_q), reference, np.array(solved), reasons, jumps,
                     waypoint_knots, info={"method": solver.name, "jump_threshold": jump_threshold})


def linear_path(solver: Solver, q0: Sequence[float], goal, samples: int = 10,
                jump_threshold: float = DEFAULT_JUMP_THRESHOLD, refinements: int = 3) -> JointPath:
    """Straight line from the tip pose at q0 to ``goal`` (SE3, 4x4 or 3-vector), ``samples`` steps."""
    return waypoint_path(solver, q0, [goal], samples, jump_threshold, refinements)


def waypoint_path(solver: Solver, q0: Sequence[float], waypoints: Sequence, samples: int = 10,
                  jump_threshold: float = DEFAULT_JUMP_THRESHOLD, refinements: int = 3) -> JointPath:
    """Straight segments from the tip pose at q0 through ``waypoints``, each in ``samples`` equal steps."""
    if samples < 1:
        raise InvalidConfigurationError(f"samples must be at least 1, got {samples}")
    q0 = solver.chain.check_q(q0)
    targets = [as_target(point) for point in waypoints]
    if not targets:
        raise InvalidTargetError("give at least one waypoint")
    pose = solver.chain.fk(q0)
    start = Target(pose.translation.copy(), pose.rotation.copy() if any(t.is_pose for t in targets) else None)
    reference = PolylineReference([start, *targets])
    count = len(targets) * samples
    s_values = np.arange(count + 1) / count
    waypoint_s = [(index + 1) / len(targets) for index in range(len(targets))]
    path = follow(solver, reference, s_values, q0, jump_threshold, refinements, waypoint_s)
    path.info.update({"kind": "cartesian", "samples_per_segment": samples, "waypoints": len(targets)})
    return path
