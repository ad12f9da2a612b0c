"""Paths of a path study: their shapes from the tip pose (p0, R0) at s_k = k / (N - 1), and the metrics of a
joint path following them (steps dq = q_j - q_i between consecutive solved points, no wrap)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.geometry import joint_gap
from wbik.study.closed_form_branches import ClosedFormBranches


def fractions(count: int) -> np.ndarray:
    """s_k = k / (N - 1), k = 0..N-1 (N >= 2)."""
    return np.arange(count) / (count - 1)


def random_unit(rng: np.random.Generator) -> np.ndarray:
    """A unit vector uniform on the sphere (a normalised standard normal vector)."""
    while True:
        vector = rng.standard_normal(3)
        norm = float(np.linalg.norm(vector))
        if norm > 1e-9:
            return vector / norm


def random_plane(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal (u, v) spanning a plane uniform among planes through the origin (Gram-Schmidt)."""
    u = random_unit(rng)
    while True:
        w = random_unit(rng)
        v = w - float(w @ u) * u
        norm = float(np.linalg.norm(v))
        if norm > 1e-6:
            return u, v / norm


def line_points(start: np.ndarray, direction: np.ndarray, length: float, count: int) -> np.ndarray:
    """(N, 3): p_k = p0 + s_k L d."""
    return np.asarray(start, float) + np.outer(fractions(count) * length, direction)


def circle_points(start: np.ndarray, u: np.ndarray, v: np.ndarray, radius: float, count: int) -> np.ndarray:
    """(N, 3): p_k = p0 + r (u (1 - cos t_k) + v sin t_k), t_k = 2 pi s_k."""
    angles = 2.0 * math.pi * fractions(count)
    return (np.asarray(start, float) + radius * (np.outer(1.0 - np.cos(angles), u)
                                                 + np.outer(np.sin(angles), v)))


def slerped_rotations(start: np.ndarray, axis: np.ndarray | None, angle: float, count: int) -> np.ndarray:
    """(N, 3, 3): R_k = R0 exp3(s_k phi a); R0 at every point for ``axis`` None."""
    if axis is None or angle == 0.0:
        return np.broadcast_to(np.asarray(start, float), (count, 3, 3)).copy()
    return np.array([start @ pin.exp3(s * angle * np.asarray(axis, float)) for s in fractions(count)])


@dataclass(frozen=True)
class PathMetrics:
    """What a joint path did: a jump is a step above a threshold, a branch change a step between known,
    different closed-form branches, a flip either."""

    points_solved: float  # share of the points solved, in [0, 1]
    whole: bool  # every point solved
    jumps: int
    branch_changes: int
    flips: int
    largest_step: float  # rad (m); NaN with fewer than two solved points
    length: float  # rad (m); 0 with fewer than two solved points


def path_metrics(q: np.ndarray, solved: np.ndarray, threshold: float,
                 branches: np.ndarray | None = None) -> PathMetrics:
    """The metrics of the joint path ``q`` (N, n) at its ``solved`` points; a jump: a step above ``threshold``
    (rad or m); ``branches`` (N,): each point's closed-form branch (-1: unknown), or None."""
    solved = np.asarray(solved, dtype=bool)
    count = solved.size
    indices = np.flatnonzero(solved)
    share = float(indices.size / count) if count else math.nan
    if indices.size < 2:
        return PathMetrics(share, bool(solved.all()) and count > 0, 0, 0, 0, math.nan, 0.0)
    steps = np.abs(np.diff(np.asarray(q, float)[indices], axis=0))  # (steps, n)
    largest = steps.max(axis=1)
    jumps = largest > threshold
    if branches is None:
        changes = np.zeros(jumps.size, dtype=bool)
    else:
        labels = np.asarray(branches)[indices]
        changes = (labels[:-1] >= 0) & (labels[1:] >= 0) & (labels[:-1] != labels[1:])
    return PathMetrics(share, bool(solved.all()), int(jumps.sum()), int(changes.sum()),
                       int((jumps | changes).sum()), float(largest.max()), float(steps.sum()))


def branch_labels(form: ClosedFormBranches, positions: np.ndarray, rotations: np.ndarray, q: np.ndarray,
                  solved: np.ndarray, tolerance: float) -> np.ndarray:
    """(N,): per solved point, the place in the closed form's list (the same sign choices at every pose) of
    the nearest branch its answer equals within ``tolerance`` (revolute modulo 2 pi), -1 for none."""
    q_all, real = form.all_branches(positions, rotations)
    revolute = ~form.chain.is_prismatic
    labels = np.full(len(positions), -1, dtype=int)
    for index in np.flatnonzero(np.asarray(solved, dtype=bool)):
        with np.errstate(invalid="ignore"):
            distance = joint_gap(q_all[index], q[index], revolute)
        distance = np.where(real[index] & np.isfinite(distance), distance, np.inf)
        nearest = int(np.argmin(distance))
        if distance[nearest] <= tolerance:
            labels[index] = nearest
    return labels
