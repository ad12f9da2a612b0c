"""Dense QP backends by name:  min 1/2 x^T H x + c^T x  s.t.  G x <= h, A x = b, lb <= x <= ub, through
qpsolvers (tolerances in ``BACKEND_OPTIONS``) or DAQP, the default, called directly on reused buffers. No
minimiser: :class:`wbik.errors.NoQPSolutionError` with the backend's status."""

from __future__ import annotations

import contextlib
import warnings
from typing import TYPE_CHECKING

import numpy as np

from wbik.errors import MissingDependencyError, NoQPSolutionError
from wbik.kernels.twins import chosen, compiled_twin

if TYPE_CHECKING:
    import qpsolvers

_STACK_ROWS = compiled_twin("qp_rows", "stack_rows")
_TIGHTEN_SLICE = compiled_twin("qp_rows", "tighten_slice")


class BackendUnavailableError(MissingDependencyError):
    """A QP backend that was asked for by name is not installed (or is no QP solver at all)."""

FASTEST = "daqp"
"""Measured fastest per QP step on the Bioloid whole body (``benchmarks/qp.py``)."""
DEFAULT = FASTEST

BACKEND_OPTIONS: dict[str, dict] = {
    "osqp": {"eps_abs": 1e-9, "eps_rel": 1e-9, "polishing": False, "max_iter": 50000, "verbose": False},
    "proxqp": {"eps_abs": 1e-10, "eps_rel": 0.0, "verbose": False},
    "daqp": {},
    "quadprog": {},
}

DAQP_EXIT_FLAGS = {1: "optimal", 2: "soft optimal", -1: "infeasible", -2: "cycling", -3: "unbounded",
                   -4: "iteration limit", -5: "nonconvex", -6: "initial working set overdetermined"}
"""DAQP's exit flags (> 0: solved)."""


def _qpsolvers():
    """qpsolvers, imported on first use (it imports every backend it finds: a third of a second)."""
    import qpsolvers

    return qpsolvers


def available() -> list[str]:
    """Backends installed here that qpsolvers can drive with dense matrices."""
    return sorted(name for name in _qpsolvers().available_solvers if name in BACKEND_OPTIONS)


def resolve(name: str) -> str:
    """A backend name ("fastest" and "default" allowed) checked against what is installed."""
    if (resolved := {"fastest": FASTEST, "default": DEFAULT}.get(name, name)) == "daqp":  # (no qpsolvers)
        with contextlib.suppress(ImportError):
            import daqp  # noqa: F401

            return resolved
    if resolved not in _qpsolvers().available_solvers:
        raise BackendUnavailableError(
            f"QP backend {name!r} is not installed; available here: {', '.join(available())}. "
            f"Install it ('pip install {resolved}'; pip install 'wbik[backends]' installs osqp, proxsuite "
            f"and quadprog) or pick one of those")
    return resolved


def solve(backend: str, H: np.ndarray, c: np.ndarray, G: np.ndarray | None, h: np.ndarray | None,
          A: np.ndarray | None, b: np.ndarray | None, lb: np.ndarray | None,
          ub: np.ndarray | None) -> np.ndarray:
    """The minimiser; raises NoQPSolutionError (with the backend's status) when there is none."""
    if backend == "daqp":
        return _solve_daqp(H, c, G, h, A, b, lb, ub)
    sparse = backend == "osqp"  # OSQP is sparse: hand it CSC matrices and keep its notices quiet
    if sparse:
        from scipy.sparse import csc_matrix  # kept out of import wbik

        H, G, A = (None if matrix is None else csc_matrix(matrix) for matrix in (H, G, A))
    return _found_solution(backend, _qpsolvers().Problem(H, c, G, h, A, b, lb, ub), quiet=sparse).x


def _found_solution(backend: str, problem: qpsolvers.Problem, quiet: bool) -> qpsolvers.Solution:
    """qpsolvers' solution with the backend's ``BACKEND_OPTIONS`` (warnings silenced when ``quiet``)."""
    qpsolvers = _qpsolvers()
    try:
        with warnings.catch_warnings(action="ignore") if quiet else contextlib.nullcontext():
            solution = qpsolvers.solve_problem(problem, solver=backend, **BACKEND_OPTIONS.get(backend, {}))
    except (ValueError, qpsolvers.SolverError) as exc:
        raise NoQPSolutionError(f"{backend} failed: {exc}", backend, str(exc)) from exc
    if not solution.found or solution.x is None:
        raise NoQPSolutionError(f"{backend} found no solution", backend, "not found")
    return solution


def solve_with_duals(backend: str, H: np.ndarray, c: np.ndarray, G: np.ndarray | None, h: np.ndarray | None,
                     A: np.ndarray | None, b: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, z, y): the minimiser and the multipliers of G x <= h and A x = b; NoQPSolutionError."""
    solution = _found_solution(backend, _qpsolvers().Problem(H, c, G, h, A, b), quiet=True)
    x = np.asarray(solution.x, dtype=float)
    # (DAQP reduces dependent equality rows away, contradictory ones included: an "optimum" off them)
    if (broken := max(float(np.max(G @ x - h, initial=0.0)) if G is not None else 0.0,
                      float(np.max(np.abs(A @ x - b), initial=0.0)) if A is not None else 0.0)) > 1e-6:
        raise NoQPSolutionError(f"{backend} returned a point that breaks its rows by {broken:.3g}", backend,
                                "infeasible")
    counts = (0 if G is None else len(G), 0 if A is None else len(A))
    z, y = (np.zeros(count) if duals is None else np.asarray(duals, dtype=float).reshape(count)
            for duals, count in zip((solution.z, solution.y), counts, strict=True))
    return x, z, y


class StackedConstraints:
    """G x <= h, A x = b and bounds as DAQP takes them, ``lower <= [I; M] x <= upper``, in reused buffers."""

    def __init__(self, n: int, capacity: int = 16):
        self.n = n
        self.rows = 0
        self._adds = 0
        # the compiled twins of add's copies and of tighten on a slice (None: NumPy's)
        self._stack_rows = chosen(None, _STACK_ROWS, "qp_rows") if n > 0 else None
        self._tighten_slice = chosen(None, _TIGHTEN_SLICE, "qp_rows")
        self._layout: list[tuple[int, int, bool]] = []
        self._views: tuple | None = None  # (rows, matrix, upper, lower, sense, key) while the layout holds
        self._matrix = np.zeros((capacity, n))
        self._upper = np.zeros(n + capacity)
        self._lower = np.zeros(n + capacity)
        self._sense = np.zeros(n + capacity, dtype=np.int32)
        self._lb, self._ub = self._lower[:n], self._upper[:n]  # views of the simple bounds
        self._scratch, self._zeros = np.zeros(n), np.zeros(n)

    def __getstate__(self) -> dict:
        """Without the views of the buffers (a copy's views must be of its own buffers: ``__setstate__``)."""
        return {name: value for name, value in self.__dict__.items() if name not in ("_lb", "_ub", "_views")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lb, self._ub = self._lower[:self.n], self._upper[:self.n]
        self._views = None

    def _grow(self, capacity: int) -> None:
        """Larger buffers, keeping the rows already added."""
        used = self.n + self.rows
        matrix, upper, lower, sense = self._matrix, self._upper, self._lower, self._sense
        kept = {name: getattr(self, name) for name in ("_layout", "_adds", "_stack_rows", "_tighten_slice")}
        self.__init__(self.n, capacity)  # (new buffers: no views kept)
        self.__dict__.update(kept)
        self.rows = used - self.n
        self._matrix[:self.rows] = matrix[:self.rows]
        self._upper[:used], self._lower[:used], self._sense[:used] = upper[:used], lower[:used], sense[:used]

    def clear(self, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """No general rows, the box |x_i| <= radius; returns (lb, ub) views to tighten in place."""
        self.rows = self._adds = 0
        self._lb.fill(-radius)
        self._ub.fill(radius)
        return self._lb, self._ub

    def tighten(self, index: np.ndarray | slice, lower, upper) -> None:
        """lb[index] <- max(lb[index], lower), ub[index] <- min(ub[index], upper)."""
        lb, ub = self._lb, self._ub
        if isinstance(index, slice):  # views: tightened in place
            start, stop = index.start or 0, index.stop
            if self._tighten_slice is not None and index.step is None and stop is not None and 0 <= start \
                    and stop <= self.n and type(lower) is np.ndarray and type(upper) is np.ndarray \
                    and lower.shape == upper.shape == (stop - start,):
                try:
                    self._tighten_slice(lb, ub, start, lower, upper)
                    return
                except TypeError:  # (not float64: NumPy converts them)
                    pass
            lb, ub = lb[index], ub[index]
            np.maximum(lb, lower, out=lb)
            np.minimum(ub, upper, out=ub)
        else:
            lb[index] = np.maximum(lb[index], lower)
            ub[index] = np.minimum(ub[index], upper)

    def close_box(self, toward_rest: bool = False) -> None:
        """Where lb > ub: lb <- ub; ``toward_rest``: ub <- max(ub, min(lb, 0)) first (back at full pace)."""
        lb, ub = self._lb, self._ub
        if toward_rest:
            scratch = self._scratch
            np.minimum(lb, self._zeros, out=scratch)  # (an array of zeros: a scalar costs a conversion)
            np.maximum(ub, scratch, out=ub)
        np.minimum(lb, ub, out=lb)

    def add(self, matrix: np.ndarray, upper: np.ndarray, equality: bool = False) -> None:
        """Rows ``matrix x <= upper`` (or ``= upper`` when ``equality``)."""
        if self.rows + (count := matrix.shape[0]) > self._matrix.shape[0]:
            self._grow(2 * (self.rows + count))
        start, stop = self.rows, self.rows + count
        first, last = self.n + start, self.n + stop
        try:
            if self._stack_rows is None:
                raise TypeError
            self._stack_rows(self._matrix, self._upper, self._lower, start, self.n, matrix, upper, equality)
        except TypeError:  # (no kernel, or not float64 arrays of these shapes: NumPy broadcasts them)
            self._matrix[start:stop] = matrix
            self._upper[first:last] = upper
            if equality:
                self._lower[first:last] = upper
        mark, layout, index = (start, count, equality), self._layout, self._adds
        if index >= len(layout) or layout[index] != mark:  # not the last QP's rows here: mark them
            del layout[index:]
            layout.append(mark)
            if not equality:
                self._lower[first:last] = -1e30
            self._sense[first:last] = 5 if equality else 0
            self._views = None
        self._adds = index + 1
        self.rows = stop

    def in_use(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bytes]:
        """(matrix, upper, lower, sense) of the rows in use and the layout's key (the sense's bytes)."""
        views = self._views
        if views is None or views[0] != self.rows:
            n, rows = self.n, self.rows
            sense = self._sense[:n + rows]
            views = self._views = (rows, self._matrix[:rows], self._upper[:n + rows], self._lower[:n + rows],
                                   sense, sense.tobytes())
        return views[1:]

    # views of the rows in use
    @property
    def matrix(self) -> np.ndarray:
        return self._matrix[:self.rows]

    @property
    def upper(self) -> np.ndarray:
        return self._upper[:self.n + self.rows]

    @property
    def lower(self) -> np.ndarray:
        return self._lower[:self.n + self.rows]

    @property
    def sense(self) -> np.ndarray:
        return self._sense[:self.n + self.rows]

    def inequality_rows(self) -> np.ndarray:
        """Indices into ``upper`` of the inequality rows (their h)."""
        return self.n + np.flatnonzero(self._sense[self.n:self.n + self.rows] == 0)

    def split(self):
        """(G, h, A, b, lb, ub) as separate arrays (None when empty), for the other backends."""
        general = slice(self.n, self.n + self.rows)
        return (*split_rows(self.matrix, self._upper[general], self._sense[general] == 5),
                self._lower[:self.n].copy(), self._upper[:self.n].copy())


def split_rows(matrix: np.ndarray, upper: np.ndarray, equality: np.ndarray) -> tuple:
    """(G, h, A, b): rows ``matrix x <= upper`` and ``= upper`` (``equality``) apart (None: none)."""
    G, h = (matrix[~equality], upper[~equality]) if np.any(~equality) else (None, None)
    A, b = (matrix[equality], upper[equality]) if np.any(equality) else (None, None)
    return G, h, A, b


class DaqpWorkspace:
    """One ``daqp.Model`` per constraint layout (``sense``), warm-started from the last active set."""

    def __init__(self):
        import daqp

        self._models: dict[bytes, object] = {}
        self._new_model = daqp.Model

    def __getstate__(self) -> dict:
        """Without DAQP's models (its workspaces cannot be copied): a copy starts its own, cold."""
        return {**self.__dict__, "_models": {}}

    def solve(self, H: np.ndarray, c: np.ndarray, constraints: StackedConstraints) -> np.ndarray:
        if constraints.rows == 0:  # (daqp.Model.update cannot take an empty general matrix)
            return _cold_daqp(H, c, constraints)
        matrix, upper, lower, sense, key = constraints.in_use()
        if (model := self._models.get(key)) is None:
            model = self._new_model()
            if model.setup(H, c, matrix, upper, lower, sense)[0] < 0:
                return _cold_daqp(H, c, constraints)
            self._models[key] = model
        elif model.update(H, c, matrix, upper, lower) < 0:
            del self._models[key]
            return _cold_daqp(H, c, constraints)
        x, _, exitflag, _ = model.solve()
        if exitflag > 0:
            return x
        del self._models[key]  # a failed solve: start the next QP of this layout afresh
        return _cold_daqp(H, c, constraints)


DAQP_RETRY = {"eps_prox": 1e-12}
"""DAQP's second try after "infeasible" or "cycling": proximal-point iterations (docs/measurements.md)."""


def _cold_daqp(H: np.ndarray, c: np.ndarray, constraints: StackedConstraints,
               settings: dict | None = None) -> np.ndarray:
    """DAQP from scratch (``settings``: DAQP's, e.g. a tighter ``primal_tol``)."""
    import daqp

    arguments = (H, c, constraints.matrix, constraints.upper, constraints.lower, constraints.sense)
    x, _, exitflag, _ = daqp.solve(*arguments, **(settings or {}))
    if exitflag > 0:
        return x
    if exitflag in (-1, -2):
        x, _, retried, _ = daqp.solve(*arguments, **{**(settings or {}), **DAQP_RETRY})
        if retried > 0:
            return x
    meaning = DAQP_EXIT_FLAGS.get(exitflag, "failed")
    raise NoQPSolutionError(f"daqp found no solution (exit flag {exitflag}: {meaning})", "daqp", exitflag)


def solve_precise(backend: str, H: np.ndarray, c: np.ndarray, constraints: StackedConstraints,
                  tolerance: float, workspace: DaqpWorkspace | None = None) -> np.ndarray:
    """The minimiser holding every inequality row to ``tolerance``: DAQP warm, cold at that primal tolerance,
    cold at its default, the first that holds or else the least breaking (docs/measurements.md)."""
    if backend != "daqp":
        return solve(backend, H, c, *constraints.split())
    rows = constraints.inequality_rows()
    matrix, upper = constraints.matrix[rows - constraints.n], constraints.upper[rows]
    attempts = ([lambda: workspace.solve(H, c, constraints)] if workspace is not None else []) + [
        lambda: _cold_daqp(H, c, constraints, {"primal_tol": tolerance}),
        lambda: _cold_daqp(H, c, constraints)]
    best, best_excess, failure = None, np.inf, None
    for attempt in attempts:
        try:
            x = attempt()
        except NoQPSolutionError as exc:
            failure = exc
            continue
        excess = float((matrix @ x[:matrix.shape[1]] - upper).max(initial=-np.inf))
        if excess <= tolerance:
            return x
        if excess < best_excess:
            best, best_excess = x, excess
    if best is None:
        raise failure
    return best


def solve_stacked(backend: str, H: np.ndarray, c: np.ndarray, constraints: StackedConstraints,
                  workspace: DaqpWorkspace | None = None) -> np.ndarray:
    """``solve`` with the constraints already stacked (DAQP takes the buffers, in ``workspace`` if given)."""
    if backend != "daqp":
        return solve(backend, H, c, *constraints.split())
    return _cold_daqp(H, c, constraints) if workspace is None else workspace.solve(H, c, constraints)


def _solve_daqp(H, c, G, h, A, b, lb, ub) -> np.ndarray:
    """DAQP called directly (the same call qpsolvers makes, without its checks and conversions)."""
    stack = StackedConstraints(c.size, sum(m.shape[0] for m in (G, A) if m is not None) or 1)
    lower, upper = stack.clear(1e30)
    lower[:], upper[:] = -1e30 if lb is None else lb, 1e30 if ub is None else ub
    for rows, bound, equality in ((G, h, False), (A, b, True)):
        if rows is not None:
            stack.add(rows, bound, equality)
    return _cold_daqp(np.ascontiguousarray(H), np.ascontiguousarray(c), stack)
