"""A family's closed form seen through a chain's own frames and joint conventions.

A closed-form family solves its arm in its own frames: a base frame, a tip frame and joint angles u
whose zero and sign are the family's. A chain of that family, described by any URDF, differs from it
by a fixed base transform G, a fixed tool transform X and, per joint, a sign and an offset:

    T_chain(q) = G T_family(u) X,        u = s * q + o   (s_i = +-1)

(:mod:`.recognition` finds G, X, s and o from the chain's structure.) :class:`AlignedForm` solves the
chain with the family's form: a target T becomes G^-1 T X^-1, a start q0 becomes s q0 + o, and every
branch u comes back as q = s (u - o); its FK composes the family's. Angles stay angles (a shift by 2 pi
of u is one of q), so wrapping into the limits and the distance to q0 are the same in both.

The family's form is built on :class:`FamilyChain`, the chain with its limits, nominal and start in
the family's joint coordinates (a family that searches inside the limits, e.g. the Pincher's pitch or
the Golem-III's position search, reads them there).
"""

from __future__ import annotations

import numpy as np

from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.structure import STRUCTURE_TOLERANCE

IDENTITY_TOLERANCE = STRUCTURE_TOLERANCE
"""A transform (entry by entry) or a joint offset (rad) this close to the identity is the identity, as
the structure's relations are decided (:data:`~.structure.STRUCTURE_TOLERANCE`): a URDF's rounding
(pi/2 written as 1.57079632679 leaves 5e-12 rad) is not a frame of its own, and a chain whose frames
are the family's (e.g. a UR URDF) keeps the family's compiled kernel. What is dropped is held to the
model like the rest (:mod:`.model_agreement`)."""


class FamilyChain:
    """A chain in a family's joint coordinates u = s * q + o: what a family's form reads of its chain
    (limits, nominal, joint kinds, names)."""

    def __init__(self, chain, signs: np.ndarray, offsets: np.ndarray):
        self.chain = chain
        self.signs, self.offsets = np.asarray(signs, dtype=float), snapped_offsets(offsets)
        signs, offsets = self.signs, self.offsets
        self.robot = chain.robot
        self.name = chain.name
        self.base_frame, self.tip_frame = chain.base_frame, chain.tip_frame
        self.joint_names = list(chain.joint_names)
        self.is_prismatic = np.asarray(chain.is_prismatic, dtype=bool).copy()
        low, high = signs * chain.lower + offsets, signs * chain.upper + offsets
        self.lower, self.upper = np.minimum(low, high), np.maximum(low, high)
        self.nominal = signs * chain.nominal + offsets
        self.mid_range = 0.5 * (self.lower + self.upper)

    @property
    def nq(self) -> int:
        return len(self.joint_names)


def snapped_offsets(offsets) -> np.ndarray:
    """Joint offsets (rad) with those within IDENTITY_TOLERANCE of zero set to zero."""
    offsets = np.asarray(offsets, dtype=float)
    return np.where(np.abs(offsets) <= IDENTITY_TOLERANCE, 0.0, offsets)


def _snapped(transform) -> tuple[bool, np.ndarray]:
    """(whether it is the identity within IDENTITY_TOLERANCE, the transform: the identity if so)."""
    transform = np.asarray(transform, dtype=float)
    if np.abs(transform - np.eye(4)).max() <= IDENTITY_TOLERANCE:
        return True, np.eye(4)
    return False, transform.copy()


class AlignedForm(ClosedForm):
    """``inner`` (a family's form on a :class:`FamilyChain`) solving ``chain``: T_chain(q) = G T(u) X,
    u = s * q + o; see the module docstring. ``base`` is G and ``tool`` X (4 x 4)."""

    def __init__(self, chain, inner: ClosedForm, base: np.ndarray, tool: np.ndarray, signs: np.ndarray,
                 offsets: np.ndarray):
        super().__init__(chain)
        self.inner = inner
        self.target_kind = inner.target_kind
        self.screen_tolerance = inner.screen_tolerance
        self.has_scalar_path = inner.has_scalar_path
        self._plain_base, self.base = _snapped(base)
        self._plain_tool, self.tool = _snapped(tool)
        self.signs = np.asarray(signs, dtype=float)
        self.offsets = snapped_offsets(offsets)
        self._plain_joints = bool(np.all(self.signs == 1.0) and not self.offsets.any())
        self._base_r, self._base_p = self.base[:3, :3].copy(), self.base[:3, 3].copy()
        self._tool_r, self._tool_p = self.tool[:3, :3].copy(), self.tool[:3, 3].copy()
        self._rows = (self._base_r.tolist(), self._base_p.tolist(), self._tool_r.tolist(),
                      self._tool_p.tolist(), self.signs.tolist(), self.offsets.tolist())
        self.kernel = None
        if self._plain_base and self._plain_joints:
            tool = None if self._plain_tool else (self._tool_r, self._tool_p)
            self.kernel = inner.compiled_kernel(tool, self.screen_tolerance)

    # -- targets and joints between the chain's frames and the family's ----------------------------
    def family_targets(self, positions: np.ndarray, rotations: np.ndarray | None):
        """G^-1 T X^-1 of targets (B, 3), (B, 3, 3) (positions only: G^-1 p, the tool has no offset)."""
        if not self._plain_base:
            positions = (positions - self._base_p) @ self._base_r
            if rotations is not None:
                rotations = np.matmul(self._base_r.T, rotations)
        if rotations is None or self._plain_tool:
            return positions, rotations
        rotations = rotations @ self._tool_r.T
        return positions - rotations @ self._tool_p, rotations

    def family_joints(self, q: np.ndarray) -> np.ndarray:
        """u = s * q + o (joints on the last axis)."""
        return q if self._plain_joints else q * self.signs + self.offsets

    def chain_joints(self, u: np.ndarray, axis: int = -1) -> np.ndarray:
        """q = s * (u - o), the joints along ``axis``."""
        if self._plain_joints:
            return u
        shape = [1] * u.ndim
        shape[axis] = -1
        return (u - self.offsets.reshape(shape)) * self.signs.reshape(shape)

    # -- the closed form --------------------------------------------------------------------------
    def branches(self, positions, rotations, q0):
        family_p, family_r = self.family_targets(positions, rotations)
        u, real = self.inner.branches(family_p, family_r, self.family_joints(q0))
        return self.chain_joints(u), real

    def branches_by_joint(self, positions, rotations, q0):
        family_p, family_r = self.family_targets(positions, rotations)
        u, real = self.inner.branches_by_joint(family_p, family_r, self.family_joints(q0))
        return self.chain_joints(u, axis=0), real

    def fk(self, q):
        position, rotation = self.inner.fk(self.family_joints(np.asarray(q, dtype=float)))
        if not self._plain_tool:
            position = position + rotation @ self._tool_p
            rotation = rotation @ self._tool_r
        if not self._plain_base:
            position = position @ self._base_r.T + self._base_p
            rotation = np.matmul(self._base_r, rotation)
        return position, rotation

    # -- the scalar path, in plain floats ------------------------------------------------------------
    def branches_one(self, position, rotation, reference):
        base_r, base_p, tool_r, tool_p, signs, offsets = self._rows
        if not self._plain_base:
            p = [a - b for a, b in zip(position, base_p, strict=True)]
            position = [sum(base_r[k][i] * p[k] for k in range(3)) for i in range(3)]
            if rotation is not None:
                rows = (rotation[0:3], rotation[3:6], rotation[6:9])
                rotation = [sum(base_r[k][i] * rows[k][j] for k in range(3))
                            for i in range(3) for j in range(3)]
        if rotation is not None and not self._plain_tool:
            rows = (rotation[0:3], rotation[3:6], rotation[6:9])
            rotation = [sum(row[k] * tool_r[j][k] for k in range(3)) for row in rows for j in range(3)]
            position = [position[i] - sum(rotation[3 * i + k] * tool_p[k] for k in range(3))
                        for i in range(3)]
        if self._plain_joints:
            return self.inner.branches_one(position, rotation, reference)
        family_reference = [s * r + o for s, r, o in zip(signs, reference, offsets, strict=True)]
        return [(bound, [s * (u - o) for s, u, o in zip(signs, q, offsets, strict=True)])
                for bound, q in self.inner.branches_one(position, rotation, family_reference)]

    def fk_one(self, q):
        base_r, base_p, tool_r, tool_p, signs, offsets = self._rows
        if not self._plain_joints:
            q = [s * value + o for s, value, o in zip(signs, q, offsets, strict=True)]
        position, rotation = self.inner.fk_one(q)
        rows = (rotation[0:3], rotation[3:6], rotation[6:9])
        if not self._plain_tool:
            position = [position[i] + sum(rows[i][k] * tool_p[k] for k in range(3)) for i in range(3)]
            rows = [[sum(row[k] * tool_r[k][j] for k in range(3)) for j in range(3)] for row in rows]
        if not self._plain_base:
            position = [sum(base_r[i][k] * position[k] for k in range(3)) + base_p[i] for i in range(3)]
            rows = [[sum(base_r[i][k] * rows[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        return tuple(position), tuple(value for row in rows for value in row)
