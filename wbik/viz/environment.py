"""Named boxes fixed in the world (stair steps, a table, a workpiece): an animation's or a robot cell's."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.collision import Obstacle
from wbik.errors import InvalidConfigurationError
from wbik.models import robot_entries

FLOOR_COLOR = 0x8C8C8C  # grey: steps, floors
TABLE_COLOR = 0xA0764A  # wood brown
PART_COLOR = 0x5B7DB1  # steel blue: workpieces
STAIR_COLORS = (0x8B5A2B, 0xA0693A, 0xB57A48, 0xC98B57, 0xDB9C66)  # wood browns, the lowest step first


@dataclass(frozen=True)
class SceneBox(Obstacle):
    """An :class:`~wbik.collision.Obstacle` drawn in RGB ``color`` with ``opacity`` in (0, 1]."""

    color: int = FLOOR_COLOR
    opacity: float = 1.0

    def __post_init__(self) -> None:
        size = tuple(float(v) for v in self.size)
        if len(size) != 3 or not all(math.isfinite(v) and v > 0 for v in size):
            raise InvalidConfigurationError(f"scene box {self.name!r}: size must be 3 positive lengths, got "
                                            f"{self.size!r}")
        for what in ("xyz", "rpy"):
            values = tuple(float(v) for v in getattr(self, what))
            if len(values) != 3 or not all(math.isfinite(v) for v in values):
                raise InvalidConfigurationError(f"scene box {self.name!r}: {what} must be 3 finite numbers")
            object.__setattr__(self, what, values)
        object.__setattr__(self, "size", size)
        if not 0.0 < float(self.opacity) <= 1.0:
            raise InvalidConfigurationError(f"scene box {self.name!r}: opacity must be in (0, 1]")

    @classmethod
    def between(cls, name: str, low, high, color: int = FLOOR_COLOR, opacity: float = 1.0) -> SceneBox:
        """The axis-aligned box from corner ``low`` to corner ``high`` (world, m)."""
        low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        return cls(name, tuple(high - low), tuple(0.5 * (low + high)), (0.0, 0.0, 0.0), color, opacity)

    def homogeneous(self) -> np.ndarray:
        """The 4 x 4 world pose of the box's centre."""
        return pin.SE3(pin.rpy.rpyToMatrix(*self.rpy), np.array(self.xyz)).homogeneous

    def corners(self) -> np.ndarray:
        """The 8 corners (8, 3) in the world."""
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        pose = self.homogeneous()
        return (0.5 * signs * self.size) @ pose[:3, :3].T + pose[:3, 3]


def robot_cell(robot) -> tuple[SceneBox, ...]:
    """The obstacles of the robot's cell (its package's ``collision_obstacles()``) as boxes."""
    entry = robot_entries().get(getattr(robot, "name", ""))
    obstacles = None if entry is None else getattr(entry.module(), "collision_obstacles", None)
    if obstacles is None:
        return ()
    return tuple(SceneBox(**vars(obstacle), color=TABLE_COLOR if "table" in obstacle.name else FLOOR_COLOR)
                 for obstacle in obstacles())
