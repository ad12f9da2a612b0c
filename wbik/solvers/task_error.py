"""The task error e(q) and its Jacobian, shared by the iterative methods.

For a full pose target (p*, R*) and tip pose (p, R) in the base frame:
    e = [p* - p ; log3(R* R^T)]   (6,)
and de/dq ~ J (the 6 x n frame Jacobian in base axes), so a Newton step solves J dq = e.
For a position target only the first three rows are used.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.robot import Chain
from wbik.targets import Target


def task_error(chain: Chain, target: Target, q: np.ndarray, with_jacobian: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """(e, J) at q; J is None when ``with_jacobian`` is False."""
    if with_jacobian:
        pose, jacobian = chain.fk_jacobian(q)
    else:
        pose, jacobian = chain.fk(q), None
    position_error = target.position - pose.translation
    if target.rotation is None:
        return position_error, None if jacobian is None else jacobian[:3]
    rotation_error = pin.log3(target.rotation @ pose.rotation.T)
    return np.concatenate((position_error, rotation_error)), jacobian


def converged(error: np.ndarray, position_tolerance: float, rotation_tolerance: float) -> bool:
    """The iterate passes the shared check (with a small safety factor)."""
    ok = np.linalg.norm(error[:3]) <= 0.5 * position_tolerance
    if error.size == 6:
        ok = ok and np.linalg.norm(error[3:]) <= 0.5 * rotation_tolerance
    return bool(ok)
