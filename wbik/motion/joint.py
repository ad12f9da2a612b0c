"""Joint-space interpolation: q(s) = q_a + s (q_b - q_a) between configurations."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from wbik.errors import InvalidConfigurationError
from wbik.motion.path import JointPath
from wbik.robot import Chain


def _checked(chain: Chain, q: Sequence[float], what: str) -> np.ndarray:
    array = chain.check_q(q)
    if not chain.in_limits(array):
        raise InvalidConfigurationError(
            f"{what} {array.tolist()} is outside the joint limits of {chain.name!r} "
            f"(lower {chain.lower.tolist()}, upper {chain.upper.tolist()})")
    return array


def joint_path(chain: Chain, configurations: Sequence[Sequence[float]], samples: int = 10) -> JointPath:
    """Joint-space lines through ``configurations`` (two or more, in limits), ``samples`` steps per line."""
    if samples < 1:
        raise InvalidConfigurationError(f"samples must be at least 1, got {samples}")
    if len(configurations) < 2:
        raise InvalidConfigurationError("a joint path needs at least two configurations")
    points = [_checked(chain, q, f"configuration {index}") for index, q in enumerate(configurations)]
    segments = len(points) - 1
    rows, s_values, waypoint_knots = [points[0]], [0.0], []
    for index in range(segments):
        start, end = points[index], points[index + 1]
        for k in range(1, samples + 1):
            rows.append(start + (k / samples) * (end - start))
            s_values.append((index + k / samples) / segments)
        waypoint_knots.append(len(rows) - 1)
    return JointPath(chain, np.array(s_values), np.array(rows), waypoint_knots=waypoint_knots,
                     info={"kind": "joint", "samples_per_segment": samples})
