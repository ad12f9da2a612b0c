"""QP backends through qpsolvers, selected by name.

Every QP step solves   min 1/2 x^T H x + c^T x   s.t.  G x <= h,  A x = b,  lb <= x <= ub
with dense matrices (24 variables for the Bioloid whole body). ``BACKEND_OPTIONS`` sets each
backend's tolerances tight enough for IK to 1e-6 (OSQP's defaults stop at 1e-3). ``FASTEST`` is
the backend measured fastest on these small dense problems by ``benchmarks/qp.py``, and the
default; OSQP stays one name away (``backend="osqp"``).

Measured here (Golem-III right arm, 150 reachable poses from the nominal start, ``wbik.solver("qp")``
with 1000 iterations allowed): DAQP 70 % solved at 2.3 ms per call (148 us per step), quadprog 70 %
at 2.9 ms (188 us per step); OSQP is 10-20x slower per step than DAQP on these small dense QPs (see
``benchmarks/qp.py``), which is why it was dropped as the default.
"""

from __future__ import annotations

import warnings

import numpy as np
import qpsolvers
from scipy import sparse

from wbik.errors import MissingDependencyError


class BackendUnavailableError(MissingDependencyError):
    """A QP backend that was asked for by name is not installed (or is no QP solver at all)."""

FASTEST = "daqp"
"""Measured fastest per QP step on the Bioloid whole body (benchmarks/qp.py; see its table)."""

DEFAULT = FASTEST
"""The default backend: the fastest measured here (dense active-set DAQP)."""

BACKEND_OPTIONS: dict[str, dict] = {
    "osqp": {"eps_abs": 1e-9, "eps_rel": 1e-9, "polishing": False, "max_iter": 50000, "verbose": False},
    "proxqp": {"eps_abs": 1e-10, "eps_rel": 0.0, "verbose": False},
    "daqp": {},
    "quadprog": {},
}


def available() -> list[str]:
    """Backends installed here that qpsolvers can drive with dense matrices."""
    return sorted(name for name in qpsolvers.available_solvers if name in BACKEND_OPTIONS)


def resolve(name: str) -> str:
    """A backend name ("fastest" and "default" allowed) checked against what is installed."""
    resolved = {"fastest": FASTEST, "default": DEFAULT}.get(name, name)
    if resolved not in qpsolvers.available_solvers:
        raise BackendUnavailableError(
            f"QP backend {name!r} is not installed; available here: {', '.join(available())}. "
            f"Install it with pip (e.g. 'pip install {resolved}') or pick one of those")
    return resolved


def solve(backend: str, H: np.ndarray, c: np.ndarray, G: np.ndarray | None, h: np.ndarray | None,
          A: np.ndarray | None, b: np.ndarray | None, lb: np.ndarray | None,
          ub: np.ndarray | None) -> np.ndarray | None:
    """The minimiser, or None when the backend finds no solution (infeasible or failed)."""
    options = BACKEND_OPTIONS.get(backend, {})
    if backend == "daqp":
        return _solve_daqp(H, c, G, h, A, b, lb, ub)
    try:
        if backend == "osqp":  # OSQP is sparse: hand it CSC matrices and keep its notices quiet
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return qpsolvers.solve_qp(sparse.csc_matrix(H), c, _csc(G), h, _csc(A), b, lb, ub,
                                          solver=backend, **options)
        return qpsolvers.solve_qp(H, c, G, h, A, b, lb, ub, solver=backend, **options)
    except (ValueError, qpsolvers.SolverError):
        return None


def _csc(matrix: np.ndarray | None):
    return None if matrix is None else sparse.csc_matrix(matrix)


def _solve_daqp(H, c, G, h, A, b, lb, ub) -> np.ndarray | None:
    """DAQP called directly (the same call qpsolvers makes, without its checks and conversions).

    DAQP takes one stacked system blower <= [I; G; A] x <= bupper whose first n rows are the
    simple bounds; ``sense`` marks the equality rows (5)."""
    import daqp

    n = c.size
    blocks = [m for m in (G, A) if m is not None]
    rows = sum(m.shape[0] for m in blocks)
    general = np.vstack(blocks) if len(blocks) > 1 else (blocks[0] if blocks else np.zeros((0, n)))
    upper = np.empty(n + rows)
    lower = np.full(n + rows, -1e30)
    upper[:n] = 1e30 if ub is None else ub
    if lb is not None:
        lower[:n] = lb
    offset = n
    if G is not None:
        upper[offset:offset + G.shape[0]] = h
        offset += G.shape[0]
    sense = np.zeros(n + rows, dtype=np.int32)
    if A is not None:
        upper[offset:] = b
        lower[offset:] = b
        sense[offset:] = 5
    x, _, exitflag, _ = daqp.solve(np.ascontiguousarray(H), np.ascontiguousarray(c),
                                   np.ascontiguousarray(general), upper, lower, sense)
    return x if exitflag > 0 else None
