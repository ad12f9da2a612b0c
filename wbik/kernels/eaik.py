"""The per-call choice of the ``eaik`` method, bit for bit as ``wbik.kernels._eaik`` in C: ``order`` writes
EAIK's branches (K, n), wrapped into the limits nearest the reference, into ``out`` nearest first by branch
and bound (:func:`bound_python`; a wrapped branch comes out once at most the next bound less ``params[0]``
away; ties in the bounds' order) and returns how many; ``choose`` writes the first whose FK
(:func:`poe_python`) passes the screen (:func:`screen_values`): joints, tip pose, check errors."""

from __future__ import annotations

import math

import numpy as np

from wbik.geometry import TWO_PI, plain_pose_errors
from wbik.kernels.twins import chosen, compiled_twin

_INVERSE_TURN = 1.0 / TWO_PI
_TURN_SQUARED = TWO_PI * TWO_PI
_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)


def parameters(joints: int, lower, upper, slack: float, limit_tolerance: float, lines=None,
               screen_tolerance: float = 0.0) -> bytes:
    """float64 values in bytes: ``slack`` (the bound's), ``limit_tolerance``, ``screen_tolerance``, lower
    (n), upper (n), and from ``lines`` (:class:`~wbik.solvers.analytic.structure.ChainLines`; zeros
    without, for ``order`` only) the joint axes (n x 3), origins (n x 3) and tip pose at q = 0 (R, p)."""
    axes, origins, tip = ((np.zeros((joints, 3)), np.zeros((joints, 3)), np.eye(4)) if lines is None
                          else (lines.axes, lines.origins, lines.tip))
    tip = np.asarray(tip, dtype=float)[:3]
    values = (slack, limit_tolerance, screen_tolerance), lower, upper, axes, origins, tip[:, :3], tip[:, 3]
    return np.concatenate([np.ravel(value) for value in values], dtype=float).tobytes()


def wrapped_python(raw: list[float], reference: list[float], lower: list[float], upper: list[float],
                   tolerance: float) -> tuple[float, list[float]] | None:
    """(squared distance, ``raw`` wrapped into the limits nearest ``reference``), or None if it cannot be."""
    wrapped, total = [], 0.0
    for value, ref, low, high in zip(raw, reference, lower, upper, strict=True):
        low_tolerant, high_tolerant = low - tolerance, high + tolerance
        turns = float(round((ref - value) / TWO_PI))
        shifted = value + turns * TWO_PI
        if low_tolerant <= shifted <= high_tolerant and -2.0 <= turns <= 2.0:
            shifted = min(max(shifted, low), high)  # max and min keep their first argument on a tie
        else:
            best, best_distance = None, math.inf
            for shift in _SHIFTS:
                candidate = value + shift
                if low_tolerant <= candidate <= high_tolerant and abs(candidate - ref) < best_distance:
                    best, best_distance = candidate, abs(candidate - ref)
            if best is None:
                return None
            shifted = min(high, max(low, best))
        wrapped.append(shifted)
        difference = shifted - ref
        total += difference * difference
    return total, wrapped


def bound_python(raw: list[float], reference: list[float]) -> float:
    """sum_i (2 pi)^2 (t_i - rint(t_i))^2, t = (q - r) / 2 pi; +inf where a joint is not finite."""
    total = 0.0
    for value, ref in zip(raw, reference, strict=True):
        turns = (value - ref) * _INVERSE_TURN
        if not math.isfinite(turns):  # C: inf - rint(inf) is NaN, the bound NaN, then +inf
            return math.inf
        turns = turns - round(turns)
        total += turns * turns * _TURN_SQUARED
    return total if total < math.inf else math.inf


def order_python(params: bytes, branches: np.ndarray, reference: np.ndarray, out: np.ndarray) -> int:
    """The Python twin of ``_eaik.order`` (see the module docstring)."""
    joints = len(reference)
    values = np.frombuffer(params, dtype=float).tolist()
    slack, tolerance = values[0], values[1]
    lower, upper = values[3:3 + joints], values[3 + joints:3 + 2 * joints]
    raws, ref = np.asarray(branches).tolist(), reference.tolist()
    bounds = [bound_python(raw, ref) for raw in raws]
    ranked = sorted(range(len(raws)), key=bounds.__getitem__)
    rows = out.reshape(-1)
    pending: list[tuple[float, int, list[float]]] = []
    written = 0
    for rank in range(len(raws) + 1):
        bound = bounds[ranked[rank]] if rank < len(raws) else math.inf
        last = rank == len(raws) or not bound < math.inf
        while pending:
            best = min(pending, key=lambda item: item[:2])  # (distance, rank): nearest, then first
            if not last and not best[0] <= bound - slack:
                break
            pending.remove(best)
            rows[written * joints:(written + 1) * joints] = best[2]
            written += 1
        if last:
            break
        if (wrapped := wrapped_python(raws[ranked[rank]], ref, lower, upper, tolerance)) is not None:
            pending.append((wrapped[0], rank, wrapped[1]))
    return written


def poe_python(values: list[float], joints: int, q: list[float]) -> list[float]:
    """The tip's 4 x 4 pose (16 values, row by row): T = T_1(q_1) ... T_n(q_n) M, T_k = (Rot(a_k, q_k),
    o_k - Rot(a_k, q_k) o_k), Rot(a, t) = cos t I + (1 - cos t) a a^T + sin t [a]x."""
    base = 3 + 2 * joints
    axes, origins = values[base:base + 3 * joints], values[base + 3 * joints:base + 6 * joints]
    tip = values[base + 6 * joints:base + 6 * joints + 12]
    r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    p = [0.0, 0.0, 0.0]
    for k in range(joints):
        ax, ay, az = axes[3 * k:3 * k + 3]
        c, s = math.cos(q[k]), math.sin(q[k])
        v = 1.0 - c
        t = [c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay,
             v * ay * ax + s * az, c + v * ay * ay, v * ay * az - s * ax,
             v * az * ax - s * ay, v * az * ay + s * ax, c + v * az * az]
        o0, o1, o2 = origins[3 * k:3 * k + 3]
        offset = [o - (t[3 * i] * o0 + t[3 * i + 1] * o1 + t[3 * i + 2] * o2)
                  for i, o in enumerate((o0, o1, o2))]
        p = [p[i] + (r[3 * i] * offset[0] + r[3 * i + 1] * offset[1] + r[3 * i + 2] * offset[2])
             for i in range(3)]
        r = [r[3 * i] * t[j] + r[3 * i + 1] * t[3 + j] + r[3 * i + 2] * t[6 + j]
             for i in range(3) for j in range(3)]
    pose = []
    for i in range(3):
        pose += [r[3 * i] * tip[j] + r[3 * i + 1] * tip[3 + j] + r[3 * i + 2] * tip[6 + j] for j in range(3)]
        pose.append(p[i] + (r[3 * i] * tip[9] + r[3 * i + 1] * tip[10] + r[3 * i + 2] * tip[11]))
    return pose + [0.0, 0.0, 0.0, 1.0]


def screen_values(reached: list[float], position: list[float], rotation: list[float],
                  tolerance: float) -> bool:
    """The screen of a tip pose (16 values) on a target (position, rotation row by row)."""
    a, b, c, x, d, e, f, y, g, h, i, z = reached[:12]
    px, py, pz = position
    dx, dy, dz = x - px, y - py, z - pz
    if not math.sqrt(dx * dx + dy * dy + dz * dz) <= tolerance:
        return False
    ra, rb, rc, rd, re, rf, rg, rh, ri = rotation
    trace = 0.0
    for product in (a * ra, b * rb, c * rc, d * rd, e * re, f * rf, g * rg, h * rh, i * ri):
        trace += product  # left to right, as the C loop
    return math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0)))) <= tolerance


def choose_python(params: bytes, branches: np.ndarray, reference: np.ndarray, target: np.ndarray,
                  out: np.ndarray) -> int:
    """The Python twin of ``_eaik.choose`` (see the module docstring)."""
    joints = len(reference)
    rows = np.empty((len(branches), joints))
    screened = order_python(params, branches, reference, rows)
    values = np.frombuffer(params, dtype=float).tolist()
    (t00, t01, t02, px), (t10, t11, t12, py), (t20, t21, t22, pz), _ = np.asarray(target).tolist()
    position, rotation = [px, py, pz], [t00, t01, t02, t10, t11, t12, t20, t21, t22]
    for q in rows[:screened].tolist():
        pose = poe_python(values, joints, q)
        if screen_values(pose, position, rotation, values[2]):
            out[:] = q + pose + plain_pose_errors(pose, position, rotation)[0]
            return 1
    return 0


order_compiled = compiled_twin("eaik", "order")
choose_compiled = compiled_twin("eaik", "choose")


def twins() -> tuple:
    """(order, choose) to run now: the compiled twins unless not built or ``WBIK_PURE_PYTHON=1``."""
    return chosen(order_python, order_compiled, "eaik"), chosen(choose_python, choose_compiled, "eaik")
