"""The support phases of a walk: double support, then per footstep a single and a double support."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.motion.walking.footsteps import OTHER, Footstep


@dataclass(frozen=True)
class Timing:
    """Phase durations (s) of a walk."""

    single_support_s: float = 0.3
    double_support_s: float = 0.1
    start_s: float = 0.4
    end_s: float = 0.6

    def __post_init__(self) -> None:
        for name in ("single_support_s", "start_s", "end_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidConfigurationError(f"{name} must be a positive number of seconds, got {value}")
        if not (math.isfinite(self.double_support_s) and self.double_support_s >= 0):
            raise InvalidConfigurationError(f"double_support_s must be >= 0 s, got {self.double_support_s}")


@dataclass(frozen=True)
class Phase:
    """A support phase (s): the ``stance`` sides, the ``feet`` at its start and the ``swing`` footstep."""

    start: float
    end: float
    stance: tuple[str, ...]
    feet: dict[str, pin.SE3]
    swing: Footstep | None = None

    @property
    def duration(self) -> float:
        return self.end - self.start

    @property
    def single(self) -> bool:
        return self.swing is not None

    def fraction(self, t: float) -> float:
        """Where t falls in the phase, clipped to [0, 1]."""
        return min(max((t - self.start) / self.duration, 0.0), 1.0) if self.duration > 0 else 1.0


def timeline(start: Mapping[str, pin.SE3], footsteps: list[Footstep], timing: Timing) -> list[Phase]:
    """The support phases of a walk through ``footsteps`` from the feet at ``start``."""
    feet = {side: placement.copy() for side, placement in start.items()}
    if not footsteps:
        return [Phase(0.0, timing.start_s + timing.end_s, ("left", "right"), dict(feet))]
    phases = [Phase(0.0, timing.start_s, ("left", "right"), dict(feet))]
    t = timing.start_s
    for index, step in enumerate(footsteps):
        phases.append(Phase(t, t + timing.single_support_s, (OTHER[step.side],), dict(feet), step))
        t += timing.single_support_s
        feet[step.side] = step.placement.copy()
        duration = timing.end_s if index == len(footsteps) - 1 else timing.double_support_s
        if duration > 0:
            phases.append(Phase(t, t + duration, ("left", "right"), dict(feet)))
            t += duration
    return phases


def phase_at(phases: list[Phase], t: float) -> Phase:
    """The phase holding time t (the last one after the end)."""
    for phase in phases:
        if t < phase.end:
            return phase
    return phases[-1]
