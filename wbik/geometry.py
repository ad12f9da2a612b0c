"""Small geometry shared by the solvers: angle wrapping and distances between joint vectors.

One rule for wrapping: ``wrap_to_pi(a)`` is the angle a - 2 pi k in (-pi, pi].
"""

from __future__ import annotations

import numpy as np


def wrap_to_pi(angle):
    """a - 2 pi k in (-pi, pi] (element-wise on arrays)."""
    return np.pi - np.mod(np.pi - np.asarray(angle, dtype=float), 2.0 * np.pi)


def joint_gap(q: np.ndarray, other: np.ndarray, revolute: np.ndarray) -> float:
    """Largest joint difference |q_i - other_i|, revolute joints taken modulo 2 pi."""
    difference = np.asarray(q, dtype=float) - other
    return float(np.max(np.where(revolute, np.abs(wrap_to_pi(difference)), np.abs(difference))))
