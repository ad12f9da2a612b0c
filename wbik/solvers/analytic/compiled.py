"""A closed form's compiled choice: its family's C kernel (``wbik/kernels/_<family>.c``) doing what
:class:`~.solver.AnalyticSolver`'s vectorised choice does, on one parameter vector."""

from __future__ import annotations

import functools
from time import perf_counter
from typing import NamedTuple

import numpy as np

from wbik.kernels.twins import pure_python
from wbik.solvers.analytic.closed_form import BRANCH_MERGE, LIMIT_TOLERANCE
from wbik.solvers.result import IKResult, Tolerances


class Alignment(NamedTuple):
    """A chain in a family's frames (:class:`~.aligned.AlignedForm`): G, X (4 x 4), s, o; None: identity."""

    base: np.ndarray | None = None
    tool: np.ndarray | None = None
    signs: np.ndarray | None = None
    offsets: np.ndarray | None = None


def _packed(transform: np.ndarray | None) -> list[float]:
    """(plain flag, rotation row by row, translation) of a 4 x 4 transform or None."""
    if transform is None:
        return [1.0, *np.eye(3).ravel(), 0.0, 0.0, 0.0]
    transform = np.asarray(transform, dtype=float)
    return [0.0, *transform[:3, :3].ravel(), *transform[:3, 3]]


class CompiledForm:
    """A family's kernel (``extension``) on one chain, its parameters packed as ``_closed_form.h`` reads."""

    def __init__(self, extension, numbers, chain, alignment: Alignment, screen_tolerance: float):
        plain_joints = alignment.signs is None
        joints = ([1.0, *np.ones(6), *np.zeros(6)] if plain_joints
                  else [0.0, *alignment.signs, *alignment.offsets])
        params = np.array([LIMIT_TOLERANCE, screen_tolerance, BRANCH_MERGE, *_packed(alignment.base),
                           *_packed(alignment.tool), *joints, *chain.lower, *chain.upper, *numbers])
        if len(params) != extension.PARAMETER_COUNT:  # the C enum and this list changed apart
            raise RuntimeError(f"{extension.__name__}: {len(params)} parameters, the C kernel reads "
                               f"{extension.PARAMETER_COUNT}; rebuild with pip install -e .")
        params.flags.writeable = False
        self.params, self.extension = params, extension
        self.branches = extension.MAX_BRANCHES
        self.nearest_into = functools.partial(extension.nearest, params)
        """nearest_into(position, rotation, reference, out) -> the chosen branch into ``out`` (6,) and the
        number of real branches, else 0 (none real), -1 (none inside the limits), -2 (none screened)."""

    def nearest_many(self, positions: np.ndarray, rotations: np.ndarray,
                     references: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``nearest_into`` for a batch without the GIL: (joints, errors (B, 8), (branches, picked))."""
        count = len(positions)
        q, errors, info = np.empty((count, 6)), np.empty((count, 8)), np.empty((count, 2))
        contiguous = np.ascontiguousarray
        self.extension.nearest_many(self.params, contiguous(positions, dtype=float),
                                    contiguous(rotations, dtype=float), contiguous(references, dtype=float),
                                    q, errors, info)
        return q, errors, info

    def distinct(self, position: np.ndarray, rotation: np.ndarray,
                 reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``solve_all``'s branches (k, 6) wrapped nearest ``reference`` and their errors (k, 8)."""
        out, errors = np.empty((self.branches, 6)), np.empty((self.branches, 8))
        count = self.extension.distinct(self.params, position, rotation, reference, out, errors)
        return out[:count], errors[:count]

    def results(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray, method: str,
                tolerances: Tolerances) -> list[IKResult]:
        """``solve_all``'s answer: an IKResult per :meth:`distinct` branch within ``tolerances``."""
        start = perf_counter()
        joints, errors = self.distinct(position, rotation, reference)
        time_s = perf_counter() - start
        position_tolerance, rotation_tolerance = tolerances.position, tolerances.rotation
        return [IKResult(q, True, "", norms[0], norms[1], position_xyz, rotation_xyz, time_s, 1, method, {})
                for q, position_xyz, rotation_xyz, norms in zip(joints, errors[:, :3], errors[:, 3:6],
                                                                 errors[:, 6:].tolist(), strict=True)
                if norms[0] <= position_tolerance and norms[1] <= rotation_tolerance]

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The kernel's FK in the chain's frames: (position (3,), rotation row by row (9,))."""
        out = np.empty(12)
        self.extension.fk(self.params, np.asarray(q, dtype=float), out)
        return out[:3], out[3:]


def compiled_form(extension, name: str, numbers, chain, alignment: Alignment | None,
                  screen_tolerance: float) -> CompiledForm | None:
    """The :class:`CompiledForm` of kernel ``name``, None where not built or ``WBIK_PURE_PYTHON`` names it."""
    if extension is None or pure_python(name):
        return None
    return CompiledForm(extension, numbers, chain, alignment or Alignment(), screen_tolerance)
