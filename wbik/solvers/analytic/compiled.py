"""A closed form's compiled choice: the C kernel of its family (``wbik/kernels/_<family>.c`` over
``_closed_form.h``) doing for one target what :class:`~.solver.AnalyticSolver` does with the form's
vectorised branches (its twin, run where the kernel is not built or ``WBIK_PURE_PYTHON`` names it).

The kernel takes the family's numbers, the chain's limits and frames (an :class:`Alignment`: T_chain(q) =
G T_family(u) X, u = s q + o) in one parameter vector. ``solve`` calls :meth:`CompiledForm.nearest_into`
and the shared check; ``solve_many`` (:meth:`nearest_many`) and ``solve_all`` (:meth:`results`) check in
C with the closed-form FK, the batched rule (the form's FK is held to the model's when it is built).
"""

from __future__ import annotations

import functools
from time import perf_counter
from typing import NamedTuple

import numpy as np

from wbik.kernels.twins import pure_python
from wbik.solvers.analytic.closed_form import BRANCH_MERGE
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE
from wbik.solvers.result import IKResult
from wbik.solvers.result import Tolerances


class Alignment(NamedTuple):
    """A chain in a family's frames and joints (:class:`~.aligned.AlignedForm`): base G and tool X (4 x 4),
    joint signs s and offsets o; None where it is the identity."""

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
    """A family's kernel (``extension``) on one chain: its ``numbers``, the chain's limits, the
    ``alignment`` and the screen's tolerance, packed as ``_closed_form.h``'s enum lays them out."""

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
        """nearest_into(position, rotation, reference, out) -> status: the branch the vectorised choice picks
        into ``out`` (6,) and the number of real branches, else 0 (no real branch), -1 (none inside the
        limits) or -2 (none passes the screen)."""

    def nearest_many(self, positions: np.ndarray, rotations: np.ndarray,
                     references: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``nearest_into`` for a batch, without the GIL: (joints (B, 6), the batched check's errors (B, 8) as
        in :meth:`distinct`, (real branches, outcome) (B, 2), outcome 1 where picked); rows not picked are
        zeros."""
        count = len(positions)
        q, errors, info = np.empty((count, 6)), np.empty((count, 8)), np.empty((count, 2))
        contiguous = np.ascontiguousarray
        self.extension.nearest_many(self.params, contiguous(positions, dtype=float),
                                    contiguous(rotations, dtype=float), contiguous(references, dtype=float),
                                    q, errors, info)
        return q, errors, info

    def distinct(self, position: np.ndarray, rotation: np.ndarray,
                 reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``solve_all``'s branches (k, 6) wrapped nearest ``reference``, in branch order, and the batched
        check's errors of each (k, 8): e_p, e_R = log3(R*^T R) (``geometry.batch_log3``'s formula), norms."""
        out, errors = np.empty((self.branches, 6)), np.empty((self.branches, 8))
        count = self.extension.distinct(self.params, position, rotation, reference, out, errors)
        return out[:count], errors[:count]

    def results(self, position: np.ndarray, rotation: np.ndarray, reference: np.ndarray, method: str,
                tolerances: Tolerances) -> list[IKResult]:
        """``solve_all``'s answer: one IKResult per :meth:`distinct` branch within ``tolerances`` (arrays
        are row views of the kernel's buffers; ``time_s`` the kernel's time with its check)."""
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
    """The :class:`CompiledForm` of kernel ``name`` (``extension``: its module, None where not built), or
    None where not built or ``WBIK_PURE_PYTHON`` names it (read now)."""
    if extension is None or pure_python(name):
        return None
    return CompiledForm(extension, numbers, chain, alignment or Alignment(), screen_tolerance)
