"""Swing-foot poses: a quintic between the footholds plus a ``clearance`` bump, at rest at both ends."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def quintic(tau):
    """10 tau^3 - 15 tau^4 + 6 tau^5 on [0, 1] (clipped; a float or an array)."""
    tau = np.clip(tau, 0.0, 1.0) if isinstance(tau, np.ndarray) else min(max(tau, 0.0), 1.0)  # a float: fast
    return tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau))


def bump(tau: float) -> float:
    """64 tau^3 (1 - tau)^3: 0 at both ends with zero first and second derivatives, 1 at tau = 1/2."""
    tau = min(max(tau, 0.0), 1.0)
    return 64.0 * (tau * (1.0 - tau)) ** 3


def swing_pose(lift_off: pin.SE3, touch_down: pin.SE3, tau: float, clearance: float) -> pin.SE3:
    """The swinging sole's world pose at fraction ``tau`` of the single support (``clearance``: m)."""
    s = quintic(tau)
    relative = pin.log3(lift_off.rotation.T @ touch_down.rotation)
    rotation = lift_off.rotation @ pin.exp3(s * relative)
    position = lift_off.translation + s * (touch_down.translation - lift_off.translation)
    position = position + np.array([0.0, 0.0, clearance * bump(tau)])
    return pin.SE3(rotation, position)
