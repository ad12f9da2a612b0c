"""The compiled scalar path of the UR-type closed form (the kernel ``ur_type`` of :mod:`wbik.kernels`).

``solve`` and ``solve_all`` of ``analytic`` on a UR-type chain spend almost all their time in the scalar
path: enumerating up to 8 branches in plain floats (:func:`.ur_type.branches_one`), wrapping them into
the limits and screening them with the closed-form FK
(:func:`wbik.solvers.analytic.closed_form.nearest_branch`).
``wbik/kernels/_ur_type.c`` is the same code in C, expression by expression, and returns the same bits
(tests compare both paths on random, boundary and singular poses). ``solve`` keeps the shared FK check
(Pinocchio) in Python; ``solve_many`` (:meth:`URKernel.nearest_many`) and ``solve_all``
(:meth:`URKernel.results`) also check in C with the closed-form FK, the batched rule ``solve_many``
always used (the form's FK is held to the model's when it is built); ``results`` builds the
IKResults from the kernel's arrays. Without the kernel, ``solve_many`` takes the NumPy batch path,
whose joints differ from the scalar path's by up to ~1e-10 rad at a stretched elbow.

The extension is built by ``pip install`` (``setup.py``, an optional extension). Without it, or with
the environment variable ``WBIK_PURE_PYTHON=1`` (:mod:`wbik.kernels`) when a closed form is built, the
Python path runs.
"""

from __future__ import annotations

import functools
from time import perf_counter
from typing import TYPE_CHECKING

import numpy as np

from wbik.kernels import PURE_PYTHON_VARIABLE  # noqa: F401 - re-exported: the switch, for this kernel's users
from wbik.kernels import pure_python
from wbik.robot import Chain
from wbik.solvers.result import IKResult
from wbik.solvers.result import Tolerances

if TYPE_CHECKING:
    from wbik.solvers.analytic.ur_type import URGeometry

try:
    from wbik.kernels import _ur_type as _ur_kernel
except ImportError:  # not built (no C compiler at install time): the Python path
    _ur_kernel = None

def built() -> bool:
    """Whether the extension was built at install time."""
    return _ur_kernel is not None


def compiled() -> bool:
    """Whether closed forms built now use the extension: built, and not turned off by
    ``WBIK_PURE_PYTHON=1``."""
    return built() and not pure_python("ur_type")


class URKernel:
    """The compiled scalar path of one UR-type chain: its DH numbers, the tolerances of the Python path,
    the chain's limits and an optional fixed tool (ee -> tool rotation and translation), packed into
    the parameter vector ``_ur_type.c`` reads (its ``enum`` gives the layout)."""

    def __init__(self, geometry: URGeometry, chain: Chain, tool: tuple[np.ndarray, np.ndarray] | None,
                 screen_tolerance: float):
        from wbik.solvers.analytic.closed_form import BOUND_SLACK
        from wbik.solvers.analytic.closed_form import BRANCH_MERGE
        from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE
        from wbik.solvers.analytic.subproblems import COSINE_TOLERANCE
        from wbik.solvers.analytic.subproblems import WRIST_SINGULARITY

        tool_rotation, tool_translation = (np.eye(3), np.zeros(3)) if tool is None else tool
        params = np.concatenate((
            [geometry.d1, geometry.a2, geometry.a3, geometry.d4, geometry.d5, geometry.d6],
            [COSINE_TOLERANCE, WRIST_SINGULARITY, LIMIT_TOLERANCE, screen_tolerance, BOUND_SLACK,
             BRANCH_MERGE, 0.0 if tool is None else 1.0],
            np.asarray(tool_rotation, dtype=float).ravel(), np.asarray(tool_translation, dtype=float),
            chain.lower, chain.upper))
        if len(params) != _ur_kernel.PARAMETER_COUNT:  # the C enum and this list changed apart
            raise RuntimeError(f"ur_kernel: {len(params)} parameters, _ur_type.c reads "
                               f"{_ur_kernel.PARAMETER_COUNT}; rebuild with pip install -e .")
        params.flags.writeable = False
        self.params = params
        self.nearest_into = functools.partial(_ur_kernel.nearest, params)
        """nearest_into(position, rotation, reference, out) -> status: :meth:`nearest` writing into
        ``out`` (6,) (the per-call path of ``solve``: no wrapper frame, no tuple)."""

    def nearest(self, position: np.ndarray, rotation: np.ndarray,
                reference: np.ndarray) -> tuple[np.ndarray | None, int]:
        """(the branch ``AnalyticSolver`` picks or None, status): the status is the number of real
        branches when one is picked, else 0 (no real branch), -1 (none inside the limits) or -2 (none
        passes the screen)."""
        out = np.empty(6)
        status = self.nearest_into(position, rotation, reference, out)
        return (out if status > 0 else None), status

    def nearest_many(self, positions: np.ndarray, rotations: np.ndarray,
                     references: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`nearest` for a batch (B, 3), (B, 3, 3), (B, 6), in one call without the GIL: (joints
        (B, 6), the batched check's errors of each with the closed-form FK (B, 8) as in :meth:`distinct`,
        (real branch count, outcome) (B, 2) with outcome 1 where a branch is picked, else the failure
        codes of :meth:`nearest`). Rows not picked hold zeros."""
        count = len(positions)
        q, errors, info = np.empty((count, 6)), np.empty((count, 8)), np.empty((count, 2))
        contiguous = np.ascontiguousarray
        _ur_kernel.nearest_many(self.params, contiguous(positions, dtype=float),
                                contiguous(rotations, dtype=float), contiguous(references, dtype=float),
                                q, errors, info)
        return q, errors, info

    def distinct(self, position: np.ndarray, rotation: np.ndarray,
                 reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The distinct screened branches wrapped nearest to ``reference``, in branch order (k, 6), and
        the batched check's errors of each with the closed-form FK (k, 8): position error xyz, rotation
        error log3(R*^T R) xyz (``geometry.batch_log3``'s formula; the screen keeps the rotation error
        below 1e-7 rad, far from the half turn where it would lose the axis), and their norms."""
        out, errors = np.empty((8, 6)), np.empty((8, 8))
        count = _ur_kernel.distinct(self.params, position, rotation, reference, out, errors)
        return out[:count], errors[:count]

    def results(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray, method: str,
                tolerances: Tolerances) -> list[IKResult]:
        """``solve_all``'s answer from :meth:`distinct`: one ``IKResult`` per branch whose errors are within
        ``tolerances`` (success, no reason, its arrays row views of the kernel's buffers, ``time_s`` the
        time of the kernel's branches and their check)."""
        start = perf_counter()
        joints, errors = np.empty((8, 6)), np.empty((8, 8))
        count = _ur_kernel.distinct(self.params, position, rotation, reference, joints, errors)
        time_s = perf_counter() - start
        position_tolerance, rotation_tolerance = tolerances.position, tolerances.rotation
        kept = errors[:count]  # row views by iteration (cheaper than indexing each)
        return [IKResult(q, True, "", norms[0], norms[1], position_xyz, rotation_xyz, time_s, 1, method, {})
                for q, position_xyz, rotation_xyz, norms in zip(joints[:count], kept[:, :3], kept[:, 3:6],
                                                                 kept[:, 6:].tolist(), strict=True)
                if norms[0] <= position_tolerance and norms[1] <= rotation_tolerance]

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The kernel's FK (position (3,), rotation row by row (9,)), tool included: for the agreement
        tests."""
        out = np.empty(12)
        _ur_kernel.fk(self.params, np.asarray(q, dtype=float), out)
        return out[:3], out[3:]


def ur_kernel(geometry: URGeometry, chain: Chain, tool: tuple[np.ndarray, np.ndarray] | None,
              screen_tolerance: float) -> URKernel | None:
    """A :class:`URKernel` for the chain, or None where the extension is not built or turned off."""
    return URKernel(geometry, chain, tool, screen_tolerance) if compiled() else None
