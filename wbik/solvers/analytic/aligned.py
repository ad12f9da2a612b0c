"""A family's closed form through a chain's own frames and joints: T_chain(q) = G T_family(u) X, u = s q + o
(s_i = +-1; G may be a reflection, as the Golem-III's left arm): a target T becomes G^-1 T X^-1, a branch u
comes back as q = s (u - o)."""

from __future__ import annotations

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.robot import Chain
from wbik.solvers.analytic.closed_form import ClosedForm
from wbik.solvers.analytic.compiled import Alignment
from wbik.solvers.analytic.structure import STRUCTURE_TOLERANCE

IDENTITY_TOLERANCE = STRUCTURE_TOLERANCE  # a transform (entries) or joint offset (rad) this near is none


class FamilyChain:
    """A chain in a family's joints u = s q + o: what a family's form reads of a chain."""

    def __init__(self, chain, signs: np.ndarray, offsets: np.ndarray):
        self.chain = chain
        self.signs, self.offsets = np.asarray(signs, dtype=float), snapped_offsets(offsets)
        signs, offsets = self.signs, self.offsets
        self.robot, self.name = chain.robot, chain.name
        self.base_frame, self.tip_frame = chain.base_frame, chain.tip_frame
        self.joint_names = list(chain.joint_names)
        self.is_prismatic = np.asarray(chain.is_prismatic, dtype=bool).copy()
        low, high = signs * chain.lower + offsets, signs * chain.upper + offsets
        self.lower, self.upper = np.minimum(low, high), np.maximum(low, high)
        self.nominal = signs * chain.nominal + offsets

    nq = Chain.nq  # len(joint_names)


def snapped_offsets(offsets) -> np.ndarray:
    """Joint offsets (rad) with those within IDENTITY_TOLERANCE of zero set to zero."""
    offsets = np.asarray(offsets, dtype=float)
    return np.where(np.abs(offsets) <= IDENTITY_TOLERANCE, 0.0, offsets)


def _snapped(transform) -> np.ndarray | None:
    """A 4 x 4 transform, or None where it is the identity within IDENTITY_TOLERANCE."""
    transform = np.asarray(transform, dtype=float)
    return None if np.abs(transform - np.eye(4)).max() <= IDENTITY_TOLERANCE else transform.copy()


def times(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a b of 3 x 3 matrices (leading axes broadcast), summed in order k = 0, 1, 2 as the kernels do."""
    return (a[..., :, 0, None] * b[..., None, 0, :] + a[..., :, 1, None] * b[..., None, 1, :]
            + a[..., :, 2, None] * b[..., None, 2, :])


def applied(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """a v of 3 x 3 matrices and 3-vectors (leading axes broadcast), summed in order k = 0, 1, 2."""
    return a[..., :, 0] * v[..., 0, None] + a[..., :, 1] * v[..., 1, None] + a[..., :, 2] * v[..., 2, None]


class AlignedForm(ClosedForm):
    """``inner`` (a family's form on a :class:`FamilyChain`) solving ``chain``, ``base`` G, ``tool`` X."""

    def __init__(self, chain, inner: ClosedForm, base: np.ndarray, tool: np.ndarray, signs: np.ndarray,
                 offsets: np.ndarray):
        super().__init__(chain)
        self.inner = inner
        self.target_kind, self.screen_tolerance = inner.target_kind, inner.screen_tolerance
        self.base, self.tool = _snapped(base), _snapped(tool)
        self.signs, self.offsets = np.asarray(signs, dtype=float), snapped_offsets(offsets)
        plain_joints = bool(np.all(self.signs == 1.0) and not self.offsets.any())
        self.alignment = Alignment(self.base, self.tool, *((None, None) if plain_joints else
                                                           (self.signs, self.offsets)))
        self.kernel = inner.compiled(chain, self.alignment, self.screen_tolerance)

    def family_targets(self, positions: np.ndarray, rotations: np.ndarray | None):
        """G^-1 T X^-1 of targets (B, 3), (B, 3, 3) (positions only: G^-1 p, the tool has no offset)."""
        base, tool = self.base, self.tool
        if base is not None:
            rotation = base[:3, :3]
            positions = applied(rotation.T, positions - base[:3, 3])
            if rotations is not None:
                rotations = times(rotation.T, rotations)
        if rotations is None or tool is None:
            return positions, rotations
        rotations = times(rotations, tool[:3, :3].T)
        return positions - applied(rotations, tool[:3, 3]), rotations

    def family_joints(self, q: np.ndarray) -> np.ndarray:
        """u = s q + o (joints on the last axis)."""
        return q if self.alignment.signs is None else q * self.signs + self.offsets

    def chain_joints(self, u: np.ndarray, axis: int = -1) -> np.ndarray:
        """q = s (u - o), the joints along ``axis``."""
        if self.alignment.signs is None:
            return u
        shape = [1] * u.ndim
        shape[axis] = -1
        return (u - self.offsets.reshape(shape)) * self.signs.reshape(shape)

    def branches(self, positions, rotations, q0):
        u, real = self.inner.branches(*self.family_targets(positions, rotations), self.family_joints(q0))
        return self.chain_joints(u), real

    def branches_by_joint(self, positions, rotations, q0):
        u, real = self.inner.branches_by_joint(*self.family_targets(positions, rotations),
                                               self.family_joints(q0))
        return self.chain_joints(u, axis=0), real

    def fk(self, q):
        position, rotation = self.inner.fk(self.family_joints(np.asarray(q, dtype=float)))
        if self.tool is not None:
            position = position + applied(rotation, self.tool[:3, 3])
            rotation = times(rotation, self.tool[:3, :3])
        if self.base is not None:
            position = applied(self.base[:3, :3], position) + self.base[:3, 3]
            rotation = times(self.base[:3, :3], rotation)
        return position, rotation


def with_tool(chain, flange_form, flange_chain: str) -> AlignedForm:
    """``flange_form`` (of chain ``flange_chain``, the same base and joints) with the tool: T_flange X."""
    flange = chain.robot.chain(flange_chain)
    if flange.joint_names != chain.joint_names or flange.base_frame != chain.base_frame:
        raise InvalidConfigurationError(
            f"{chain.name!r} ({chain.base_frame} -> {chain.tip_frame} over {chain.joint_names}) is not "
            f"{flange.name!r} ({flange.base_frame} -> {flange.tip_frame} over {flange.joint_names}) with a "
            "tool: a tool closed form needs the same base and joints")
    tool = (flange.fk(flange.nominal).inverse() * chain.fk(chain.nominal)).homogeneous
    return AlignedForm(chain, flange_form(flange), np.eye(4), tool, np.ones(chain.nq), np.zeros(chain.nq))
