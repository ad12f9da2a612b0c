"""Checks shared by the closed-form tests (test_analytic_*.py)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


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


def fk_error(chain, q: np.ndarray, target: pin.SE3 | np.ndarray) -> float:
    """max(|p - p*|, |log3(R*^T R)|) of joints q against a pose, or |p - p*| against a position, by the
    chain's FK."""
    reached = chain.fk(q)
    if isinstance(target, np.ndarray):
        return float(np.linalg.norm(reached.translation - target))
    return max(float(np.linalg.norm(reached.translation - target.translation)),
               float(np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))))


def solved_inside_limits(solver, joints: np.ndarray) -> int:
    """How many FK poses of ``joints`` ``solver.solve`` solves from the nominal start; every answer it calls
    solved is within 1e-6 by FK and inside the limits (asserted)."""
    chain, solved = solver.chain, 0
    for q in joints:
        target = chain.fk(q)
        result = solver.solve(target, q0=chain.nominal)
        if result.success:
            solved += 1
            assert fk_error(chain, result.q, target) <= 1e-6
            assert np.all(result.q >= chain.lower - 1e-9) and np.all(result.q <= chain.upper + 1e-9)
    return solved
