"""Checks shared by the closed-form tests (test_analytic_*.py)."""

from __future__ import annotations

import numpy as np


def angle_difference(a, b) -> np.ndarray:
    """|a - b| modulo 2 pi, in [0, pi] (element-wise), computed independently of wbik's wrap."""
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def assert_pose_round_trip(solver, joints: np.ndarray, poses: list, branch_starts: np.ndarray) -> None:
    """solve_many on FK poses of ``joints``: >= 99.99 % solved, every answer inside the limits and within
    the shared tolerances, and for >= 99.9 % of the poses a real branch (``branch_starts`` as q0) equal to
    the original joints up to 2 pi."""
    chain = solver.chain
    results = solver.solve_many(poses)
    assert np.mean([r.success for r in results]) >= 0.9999
    for result in results:
        if result.success:
            assert chain.in_limits(result.q)
            assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
    form = solver.closed_form("pose")
    branches, real = form.branches(np.array([p.translation for p in poses]),
                                   np.array([p.rotation for p in poses]), branch_starts)
    match = np.all(angle_difference(branches, joints[:, None, :]) < 1e-7, axis=-1) & real
    assert match.any(axis=1).mean() >= 0.999
