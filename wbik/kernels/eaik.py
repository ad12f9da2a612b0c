"""The per-call choice of the ``eaik`` method (:meth:`wbik.solvers.eaik.EAIKSolver.solve`) in two
twins with the same bits: :func:`order_python` and :func:`choose_python` here, and the C extension
``wbik.kernels._eaik`` (``_eaik.c``, expression by expression the same code).

* ``order(params, branches, reference, out) -> count``: of EAIK's branches (K, n), the ones the choice
  screens, wrapped into the limits nearest to ``reference``, written into ``out`` (at least K * n
  float64 values, C order) in the order they are screened; returns how many. The order is that of
  branch and bound: each branch's lower bound of its squared distance once wrapped,
  sum_i (2 pi)^2 (t_i - rint(t_i))^2 with t = (q - r) / 2 pi (+inf where a joint is not finite),
  branches taken in the (stable) order of their bounds; before each is taken, every wrapped branch whose
  squared distance is at most its bound less ``params[0]`` (n BOUND_SLACK) comes out, nearest first
  (ties: the first in the bounds' order), and after the last one (or at an infinite bound) all of them.
  Because no branch left can be nearer, this is the order of the wrapped distances; the caller screens
  the rows in turn and takes the first that passes.
* ``choose(params, branches, reference, target, out) -> 0 or 1``: the first of ``order``'s rows whose
  FK passes the screen on the target (its 4 x 4 homogeneous matrix). ``out`` (n + 24 values) gets its
  joints (n), its 4 x 4 tip pose (16) and the batched check's errors of that pose (8:
  :func:`pose_errors_python`, the rule of :func:`wbik.solvers.analytic.batch.evaluate_batch`). The FK
  is the product of exponentials of the chain's joint lines (:func:`poe_python`; the model's FK to
  rounding, held to it when the solver is built), the screen |p - p*| <= tolerance, then
  acos(clip((trace(R*^T R) - 1) / 2)) <= tolerance with the trace summed row by row (as
  :func:`wbik.solvers.analytic.closed_form.screen_residual`).

The C code builds no Python object but the returned int. :func:`parameters` packs what both read
(float64 values in a bytes object). ``WBIK_PURE_PYTHON=1`` (:mod:`wbik.kernels`) when the solver is
built, or no built extension, runs the Python twin. tests/test_eaik_kernel.py holds both to the same
bits.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.geometry import TWO_PI
from wbik.kernels.twins import chosen
from wbik.kernels.twins import compiled_twin

_INVERSE_TURN = 1.0 / TWO_PI
_TURN_SQUARED = TWO_PI * TWO_PI
_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)


def parameters(joints: int, lower, upper, slack: float, limit_tolerance: float, lines=None,
               screen_tolerance: float = 0.0) -> bytes:
    """The parameters of ``order`` and ``choose``, float64 values packed in bytes: (``slack``, the bound's
    slack, n BOUND_SLACK; ``limit_tolerance``; the screen's tolerance; lower (n); upper (n); the joint
    lines' axes (n x 3) and origins (n x 3); the tip's pose at q = 0: rotation (3 x 3) and position
    (3)). ``lines``: the chain's :class:`~wbik.solvers.analytic.structure.ChainLines` (zeros without:
    ``order`` only)."""
    if lines is None:
        axes, origins, tip = np.zeros((joints, 3)), np.zeros((joints, 3)), np.eye(4)
    else:
        axes, origins, tip = lines.axes, lines.origins, lines.tip
    tip = np.asarray(tip, dtype=float)
    params = np.concatenate((
        [slack, limit_tolerance, screen_tolerance], np.asarray(lower, dtype=float),
        np.asarray(upper, dtype=float), np.asarray(axes, dtype=float).ravel(),
        np.asarray(origins, dtype=float).ravel(), tip[:3, :3].ravel(), tip[:3, 3]))
    return params.tobytes()


def wrapped_python(raw: list[float], reference: list[float], lower: list[float], upper: list[float],
                   tolerance: float) -> tuple[float, list[float]] | None:
    """(squared distance to ``reference``, ``raw`` wrapped into the limits nearest to it) or None when a
    joint has no 2 pi shift inside its limits: :func:`wbik.solvers.analytic.closed_form.wrap_one_into_limits`
    and
    :func:`~wbik.solvers.analytic.squared_distance`, joint by joint."""
    wrapped = []
    total = 0.0
    for value, ref, low, high in zip(raw, reference, lower, upper, strict=True):
        low_tolerant, high_tolerant = low - tolerance, high + tolerance
        turns = float(round((ref - value) / TWO_PI))
        shifted = value + turns * TWO_PI
        if low_tolerant <= shifted <= high_tolerant and -2.0 <= turns <= 2.0:
            if shifted > high:
                shifted = high
            elif shifted < low:
                shifted = low
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
    """sum_i (2 pi)^2 (t_i - rint(t_i))^2, t = (q - r) / 2 pi, joint by joint; +inf where a joint is
    not finite."""
    total = 0.0
    for value, ref in zip(raw, reference, strict=True):
        turns = (value - ref) * _INVERSE_TURN
        if not math.isfinite(turns):  # C: inf - rint(inf) is NaN, the bound NaN, then +inf
            return math.inf
        turns = turns - round(turns)
        total += turns * turns * _TURN_SQUARED
    return total if total < math.inf else math.inf


def order_python(params: bytes, branches: np.ndarray, reference: np.ndarray, out: np.ndarray) -> int:
    """The Python twin of ``_eaik_kernel.order`` (see the module docstring)."""
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
        wrapped = wrapped_python(raws[ranked[rank]], ref, lower, upper, tolerance)
        if wrapped is not None:
            pending.append((wrapped[0], rank, wrapped[1]))
    return written


def poe_python(values: list[float], joints: int, q: list[float]) -> list[float]:
    """The tip's 4 x 4 pose (16 values, row by row) of joints ``q`` from the packed parameters' lines:
    T = T_1(q_1) ... T_n(q_n) M, T_k = (Rot(a_k, q_k), o_k - Rot(a_k, q_k) o_k),
    Rot(a, t) = cos t I + (1 - cos t) a a^T + sin t [a]x; the C twin's operations in its order."""
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
    """The screen on a tip pose (16 values, row by row) and a target (position, rotation row by row)."""
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


def pose_errors_python(reached: list[float], position: list[float], rotation: list[float]) -> list[float]:
    """The batched check's errors of a tip pose (16 values, row by row) against a target (position,
    rotation row by row): (e_p (3), e_R (3), |e_p|, |e_R|), e_R = log3(M), M = R*^T R, in
    :func:`wbik.geometry.batch_log3`'s formula: vee(M - M^T) angle / |vee|, angle = atan2(|vee| / 2,
    (trace M - 1) / 2) (``_pose_errors.h``, operation by operation)."""
    r00, r01, r02, x, r10, r11, r12, y, r20, r21, r22, z = reached[:12]
    t00, t01, t02, t10, t11, t12, t20, t21, t22 = rotation
    m = [t00 * r00 + t10 * r10 + t20 * r20, t00 * r01 + t10 * r11 + t20 * r21,
         t00 * r02 + t10 * r12 + t20 * r22, t01 * r00 + t11 * r10 + t21 * r20,
         t01 * r01 + t11 * r11 + t21 * r21, t01 * r02 + t11 * r12 + t21 * r22,
         t02 * r00 + t12 * r10 + t22 * r20, t02 * r01 + t12 * r11 + t22 * r21,
         t02 * r02 + t12 * r12 + t22 * r22]
    vee = (m[7] - m[5], m[2] - m[6], m[3] - m[1])
    twice_sine = math.sqrt(vee[0] * vee[0] + vee[1] * vee[1] + vee[2] * vee[2])
    cosine = 0.5 * (m[0] + m[4] + m[8] - 1.0)
    scale = math.atan2(0.5 * twice_sine, cosine) / max(twice_sine, 1e-300)
    ex, ey, ez = x - position[0], y - position[1], z - position[2]
    rx, ry, rz = vee[0] * scale, vee[1] * scale, vee[2] * scale
    return [ex, ey, ez, rx, ry, rz, math.sqrt(ex * ex + ey * ey + ez * ez),
            math.sqrt(rx * rx + ry * ry + rz * rz)]


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
            out[:] = q + pose + pose_errors_python(pose, position, rotation)
            return 1
    return 0


order_compiled = compiled_twin("eaik", "order")
choose_compiled = compiled_twin("eaik", "choose")


def built() -> bool:
    """Whether the extension was built at install time."""
    return choose_compiled is not None


def twins() -> tuple:
    """(order, choose) to run now: the compiled twins unless not built or ``WBIK_PURE_PYTHON=1``."""
    return chosen(order_python, order_compiled, "eaik"), chosen(choose_python, choose_compiled, "eaik")
