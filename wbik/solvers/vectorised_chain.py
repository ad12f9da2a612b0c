"""Task residuals and Jacobians of B configurations of a serial chain in a fixed number of numpy calls: with
each joint frame turned so its axis is z, T(q) = F_1 A_1(q_1) ... A_n(q_n), A_k = Z(q_k) Q_k^T P_k Q_{k+1},
Z(q) = I + f K + g K^2 (f = sin q, g = 1 - cos q, K = [e_z]x; prismatic: I + q E_z): every A_k = [1, f, g]
[C0; C1; C2]_k from one matrix product, then n products down the chain.
"""

from __future__ import annotations

import numpy as np

from wbik.solvers.task_error import LEVI_CIVITA, batch_se3_error, serial_structure

# rows of the (B, 2n) x (2n, 16n) product per BLAS call: under OpenBLAS's threading threshold
# (M N K <= 4 x 65536) for chains of up to 8 joints: a large batch wakes no second thread, which would
# then spin between the calls
ROWS_PER_PRODUCT = 128


class VectorisedChain:
    """Residuals and transposed Jacobians (B, n, m) of B configurations, position rows weighted by
    ``position_weight``: column k [z_k x (p - o_k); z_k] (revolute) or [z_k; 0] (prismatic)."""

    def __init__(self, chain, position_weight: float = 1.0):
        structure = serial_structure(chain)
        n = chain.nq
        turns = [np.eye(4) for _ in range(n + 1)]
        for k, axis in enumerate(structure.axes):
            turns[k][:3, :3] = rotation_taking_z_to(axis)
        placements = structure.placements
        self.first = placements[0] @ turns[0]
        cross_z = np.zeros((4, 4))
        cross_z[0, 1], cross_z[1, 0] = -1.0, 1.0
        along_z = np.zeros((4, 4))
        along_z[2, 3] = 1.0
        # A_k flattened = C0_k + f_k C1_k + g_k C2_k; F_1 is folded into A_1 (its frame is constant)
        constant = np.zeros((n, 16))
        linear = np.zeros((2 * n, 16 * n))  # rows: f_1..f_n, g_1..g_n; column block k: joint k
        for k in range(n):
            placement = turns[k].T @ placements[k + 1] @ turns[k + 1]
            before = self.first if k == 0 else np.eye(4)
            columns = slice(16 * k, 16 * (k + 1))
            constant[k] = (before @ placement).reshape(16)
            if structure.prismatic[k]:
                linear[k, columns] = (before @ along_z @ placement).reshape(16)
            else:
                linear[k, columns] = (before @ cross_z @ placement).reshape(16)
                linear[n + k, columns] = (before @ cross_z @ cross_z @ placement).reshape(16)
        self.n, self.constant, self.linear = n, constant.reshape(16 * n), linear
        self.prismatic = structure.prismatic
        self.any_prismatic = bool(self.prismatic.any())
        self.weight = float(position_weight)
        self._cross = self.weight * LEVI_CIVITA  # (a outer b).flat @ this = weight * (a x b)

    def evaluate(self, q: np.ndarray, goal_position: np.ndarray, goal_rotation: np.ndarray | None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(e (B, m), J^T (B, n, m)) against one goal or one per row: e = log6(T*^-1 T) with the tip-axes
        Jacobian, both turned into base axes, or e = w (p - p*) with the linear rows."""
        size, n = q.shape
        frames = self.frames(q)
        axes = frames[:, :n, :3, 2]
        tip = frames[:, n]
        position = tip[:, :3, 3]
        lever = position[:, None, :] - frames[:, :n, :3, 3]
        pose = goal_rotation is not None
        transposed = np.empty((size, n, 6 if pose else 3))
        transposed[..., :3] = (axes[..., :, None] * lever[..., None, :]).reshape(size, n, 9) @ self._cross
        if self.any_prismatic:
            transposed[:, self.prismatic, :3] = self.weight * axes[:, self.prismatic]
        if not pose:
            error = position - goal_position
            if self.weight != 1.0:
                error *= self.weight
            return error, transposed
        transposed[..., 3:] = axes
        if self.any_prismatic:
            transposed[:, self.prismatic, 3:] = 0.0
        rotation = tip[:, :3, :3]
        error = batch_se3_error(rotation, self.weight * position, goal_rotation, self.weight * goal_position)
        # turning both 3-blocks of e by R instead of J (tip axes: R^T J) keeps |e|, J^T J and J^T e
        error = np.matmul(error.reshape(size, 2, 3), np.swapaxes(rotation, 1, 2)).reshape(size, 6)
        return error, transposed

    def tip_poses(self, q: np.ndarray) -> np.ndarray:
        """(B, 4, 4) tip poses in the base frame."""
        return self.frames(q)[:, -1]

    def frames(self, q: np.ndarray) -> np.ndarray:
        """(B, n + 1, 4, 4): the n joint frames (z = the joint axis) and the tip frame, base frame."""
        size, n = q.shape
        coefficients = np.empty((size, 2 * n))
        np.sin(q, out=coefficients[:, :n])
        np.cos(q, out=coefficients[:, n:])
        np.subtract(1.0, coefficients[:, n:], out=coefficients[:, n:])
        if self.any_prismatic:
            coefficients[:, :n][:, self.prismatic] = q[:, self.prismatic]
        steps = np.empty((size, 16 * n))
        for first in range(0, size, ROWS_PER_PRODUCT):  # row blocks: OpenBLAS keeps each on one thread
            np.dot(coefficients[first:first + ROWS_PER_PRODUCT], self.linear,
                   out=steps[first:first + ROWS_PER_PRODUCT])
        steps = (steps + self.constant).reshape(size, n, 4, 4)
        frames = np.empty((size, n + 1, 4, 4))
        frames[:, 0] = self.first
        frames[:, 1] = steps[:, 0]
        for k in range(1, n):
            np.matmul(frames[:, k], steps[:, k], out=frames[:, k + 1])
        return frames


def rotation_taking_z_to(axis: np.ndarray) -> np.ndarray:
    """A rotation Q with Q e_z = axis (a unit vector)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(axis, x), axis))
