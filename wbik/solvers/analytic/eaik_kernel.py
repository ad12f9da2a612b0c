"""The per-call choice of the ``eaik`` method (:meth:`wbik.solvers.eaik.EAIKSolver._choose`) in two
twins with the same bits: :func:`order_python` and :func:`screen_python` here, and the C extension
``_eaik_kernel`` (``_eaik_kernel.c``, expression by expression the same code).

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
* ``screen(reached, position, rotation, tolerance) -> bool``: the FK screen on a tip placement computed
  by the caller (Pinocchio's 4 x 4 homogeneous matrix): |p - p*| <= tolerance, then
  acos(clip((trace(R*^T R) - 1) / 2)) <= tolerance with the trace summed row by row (as
  :func:`wbik.solvers.analytic.screen_residual`).

No FK here, and the C code builds no Python object but the returned int or bool. :func:`parameters`
packs what ``order`` reads (float64 values in a bytes object). ``WBIK_PURE_PYTHON=1``
(:mod:`wbik.compiled`) when the solver is built, or no built extension, runs the Python twin.
tests/test_eaik_kernel.py holds both to the same bits.
"""

from __future__ import annotations

import math

import numpy as np

from wbik.compiled import chosen
from wbik.compiled import compiled_twin
from wbik.geometry import TWO_PI

_INVERSE_TURN = 1.0 / TWO_PI
_TURN_SQUARED = TWO_PI * TWO_PI
_SHIFTS = (0.0, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI)


def parameters(joints: int, lower, upper) -> bytes:
    """The parameters of ``order``, float64 values packed in bytes: (n BOUND_SLACK, LIMIT_TOLERANCE,
    lower (n), upper (n))."""
    from wbik.solvers.analytic import BOUND_SLACK
    from wbik.solvers.analytic import LIMIT_TOLERANCE

    params = np.concatenate(([joints * BOUND_SLACK, LIMIT_TOLERANCE], np.asarray(lower, dtype=float),
                             np.asarray(upper, dtype=float)))
    return params.tobytes()


def wrapped_python(raw: list[float], reference: list[float], lower: list[float], upper: list[float],
                   tolerance: float) -> tuple[float, list[float]] | None:
    """(squared distance to ``reference``, ``raw`` wrapped into the limits nearest to it) or None when a
    joint has no 2 pi shift inside its limits: :func:`wbik.solvers.analytic.wrap_one_into_limits` and
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
    lower, upper = values[2:2 + joints], values[2 + joints:2 + 2 * joints]
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


def screen_python(reached: np.ndarray, position: np.ndarray, rotation: np.ndarray, tolerance: float) -> bool:
    """The Python twin of ``_eaik_kernel.screen`` (see the module docstring)."""
    (a, b, c, x), (d, e, f, y), (g, h, i, z), _ = reached.tolist()
    px, py, pz = position.tolist()
    dx, dy, dz = x - px, y - py, z - pz
    if not math.sqrt(dx * dx + dy * dy + dz * dz) <= tolerance:
        return False
    (ra, rb, rc), (rd, re, rf), (rg, rh, ri) = rotation.tolist()
    trace = 0.0
    for product in (a * ra, b * rb, c * rc, d * rd, e * re, f * rf, g * rg, h * rh, i * ri):
        trace += product  # left to right, as Python 3.11's sum() and the C loop
    return math.acos(min(1.0, max(-1.0, 0.5 * (trace - 1.0)))) <= tolerance


order_compiled = compiled_twin("wbik.solvers.analytic._eaik_kernel", "order")
screen_compiled = compiled_twin("wbik.solvers.analytic._eaik_kernel", "screen")


def built() -> bool:
    """Whether the extension was built at install time."""
    return order_compiled is not None


def twins() -> tuple:
    """(order, screen) to run now: the compiled twins unless not built or ``WBIK_PURE_PYTHON=1``."""
    return chosen(order_python, order_compiled), chosen(screen_python, screen_compiled)
