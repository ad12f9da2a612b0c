"""Footsteps: the centre frame between the feet moves by C_i = C_(i-1) SE3(Rz(d_theta), (dx, dy, 0)) per
step, the stepping foot lands at its start offset from it, and a closing step brings the feet together."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.qp.support_polygon import SupportPolygon
from wbik.robot import Robot

SIDES = ("left", "right")
OTHER = {"left": "right", "right": "left"}
CLOSING_TOLERANCE = 1e-6  # m or rad: a closing step that moves the foot less is left out


def yaw_of(rotation: np.ndarray) -> float:
    """Heading (rad) of a rotation: the angle of its x axis in the ground plane."""
    return float(math.atan2(rotation[1, 0], rotation[0, 0]))


@dataclass(frozen=True)
class Feet:
    """The two sole frames of a biped, by side."""

    left: str
    right: str

    def frame(self, side: str) -> str:
        return self.left if side == "left" else self.right

    def side(self, frame: str) -> str:
        if frame not in (self.left, self.right):
            raise InvalidConfigurationError(f"{frame!r} is neither foot ({self.left}, {self.right})")
        return "left" if frame == self.left else "right"

    @property
    def frames(self) -> tuple[str, str]:
        return (self.left, self.right)

    @classmethod
    def of(cls, robot: Robot, left: str | None = None, right: str | None = None) -> Feet:
        """The feet named, or the two soles of ``robot.soles`` (the left one at the larger y)."""
        if left is not None and right is not None:
            for frame in (left, right):
                if frame not in robot.soles:
                    raise InvalidConfigurationError(f"foot {frame!r} is not a sole of {robot.name!r} "
                                                    f"(robot.soles: {sorted(robot.soles)})")
            return cls(left, right)
        soles = list(robot.soles)
        if len(soles) != 2:
            raise InvalidConfigurationError(
                f"a biped walk needs two soles; {robot.name!r} lists {len(soles)} ({soles}): name the feet")
        y_a, y_b = (robot.frame_placement(robot.nominal, frame).translation[1] for frame in soles)
        return cls(*soles) if y_a > y_b else cls(*reversed(soles))


@dataclass(frozen=True)
class Footstep:
    """A foot put down: its ``side``, sole ``frame`` and world ``placement`` (the sole frame's pose)."""

    side: str
    frame: str
    placement: pin.SE3

    @property
    def yaw(self) -> float:
        return yaw_of(self.placement.rotation)


@dataclass(frozen=True)
class StepCommand:
    """``steps`` steps, each moving the centre frame ``length`` forward, ``lateral`` to the left (m) and
    turning it ``turn_deg`` to the left; ``first``: the first foot (None: the side it moves or turns to)."""

    steps: int = 4
    length: float = 0.03
    lateral: float = 0.0
    turn_deg: float = 0.0
    first: str | None = None

    def __post_init__(self) -> None:
        if int(self.steps) != self.steps or self.steps < 0:
            raise InvalidConfigurationError(f"steps must be an integer >= 0, got {self.steps}")
        for name in ("length", "lateral", "turn_deg"):
            if not math.isfinite(getattr(self, name)):
                raise InvalidConfigurationError(f"{name} must be finite, got {getattr(self, name)}")
        if abs(self.turn_deg) > 45.0:
            raise InvalidConfigurationError(f"turn at most 45 deg per step, got {self.turn_deg}")
        if self.first not in (None, *SIDES):
            raise InvalidConfigurationError(f"first must be 'left', 'right' or null, got {self.first!r}")

    @property
    def first_side(self) -> str:
        return self.first or ("right" if (self.lateral or self.turn_deg) < 0 else "left")

    @property
    def kind(self) -> str:
        """straight, sideways, turning, in place or standing (what the command mostly does)."""
        if self.steps == 0:
            return "standing"
        if self.length == 0 and self.lateral == 0:
            return "in place" if self.turn_deg == 0 else "turning in place"
        if self.turn_deg:
            return "turning"
        return "sideways" if abs(self.lateral) > abs(self.length) else "straight"


def mean_yaw(left: pin.SE3, right: pin.SE3) -> float:
    """The feet's mean heading (rad)."""
    yaw_left, yaw_right = yaw_of(left.rotation), yaw_of(right.rotation)
    return yaw_right + 0.5 * math.remainder(yaw_left - yaw_right, 2 * math.pi)


def centre_frame(left: pin.SE3, right: pin.SE3) -> pin.SE3:
    """Between the feet, yawed like them (mean heading), at their mean height."""
    return pin.SE3(pin.utils.rotate("z", mean_yaw(left, right)), 0.5 * (left.translation + right.translation))


def sole_points(robot: Robot, frame: str, placement: pin.SE3) -> np.ndarray:
    """The sole's contact points (``robot.soles``) in the world with the sole frame at ``placement``."""
    return np.asarray(robot.soles[frame]) @ placement.rotation.T + placement.translation


def placed_on(robot: Robot, q: np.ndarray, anchor_frame: str, placement: pin.SE3) -> np.ndarray:
    """q with the floating base moved so that ``anchor_frame`` is at ``placement`` (world)."""
    q = q.copy()
    q[:7] = pin.SE3ToXYZQUAT(pin.SE3.Identity())
    in_base = robot.frame_placement(q, anchor_frame)
    q[:7] = pin.SE3ToXYZQUAT(placement * in_base.inverse())
    return q


def clip_points(points: np.ndarray, x_max: float | None) -> np.ndarray:
    """The part x <= ``x_max`` (all for None) of a convex polygon (k, 2) (Sutherland-Hodgman)."""
    if x_max is None:
        return points
    vertices = np.asarray(points, dtype=float)
    kept = []
    for index, current in enumerate(vertices):
        following = vertices[(index + 1) % len(vertices)]
        inside, next_inside = current[0] <= x_max, following[0] <= x_max
        if inside:
            kept.append(current)
        if inside != next_inside:
            fraction = (x_max - current[0]) / (following[0] - current[0])
            kept.append(current + fraction * (following - current))
    return np.array(kept)


def sole_polygon(robot: Robot, placements: Mapping[str, pin.SE3],
                 clip_x: Mapping[str, float] | None = None) -> SupportPolygon:
    """The support polygon of the soles (frame -> placement) on the ground, each cut at its ``clip_x``."""
    cut = clip_x or {}
    return SupportPolygon(np.vstack([clip_points(sole_points(robot, frame, p)[:, :2], cut.get(frame))
                                     for frame, p in placements.items()]))


def plan_footsteps(start: Mapping[str, pin.SE3], command: StepCommand, feet: Feet) -> list[Footstep]:
    """The footsteps of ``command`` from the feet at ``start`` ({"left": SE3, "right": SE3})."""
    centre = centre_frame(start["left"], start["right"])
    offsets = {side: centre.actInv(start[side]) for side in SIDES}
    width = float(offsets["left"].translation[1] - offsets["right"].translation[1])
    if width <= 0:
        raise InvalidConfigurationError(f"the left foot must be left of the right one (width {width:.4f} m)")
    if command.lateral and abs(command.lateral) >= width:
        raise InvalidConfigurationError(
            f"a lateral step of {command.lateral} m would cross the feet (stance width {width:.4f} m)")
    move = pin.SE3(pin.utils.rotate("z", math.radians(command.turn_deg)),
                   np.array([command.length, command.lateral, 0.0]))
    leading = None if not command.lateral else ("left" if command.lateral > 0 else "right")
    outward = pin.SE3(np.eye(3), np.array([0.0, command.lateral, 0.0]))
    footsteps, side = [], command.first_side
    for _ in range(command.steps):
        centre = centre * move
        placement = (centre * outward if side == leading else centre) * offsets[side]
        footsteps.append(Footstep(side, feet.frame(side), placement))
        side = OTHER[side]
    if command.steps:
        last = footsteps[-1]
        closing = last.placement * offsets[last.side].inverse() * offsets[side]
        previous = next((f.placement for f in reversed(footsteps) if f.side == side), start[side])
        if (np.linalg.norm(closing.translation - previous.translation) > CLOSING_TOLERANCE
                or np.linalg.norm(pin.log3(previous.rotation.T @ closing.rotation)) > CLOSING_TOLERANCE):
            footsteps.append(Footstep(side, feet.frame(side), closing))
    return footsteps

