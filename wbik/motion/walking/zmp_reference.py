"""The ZMP reference: the stance sole's centre in single support, a quintic from sole to sole in double
support, from the CoM's start and to between the last two soles at the ends."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from wbik.motion.walking.swing import quintic
from wbik.motion.walking.timeline import Phase

Centre = Callable[[str, pin.SE3], np.ndarray]  # (side, sole placement) -> the sole's centre (x, y)


def sole_centres(robot, feet, forward: float = 0.0) -> Centre:
    """The ZMP target of a sole at a placement: its contact points' centroid, ``forward`` m ahead."""
    local = {side: np.asarray(robot.soles[feet.frame(side)], dtype=float).mean(axis=0) + [forward, 0.0, 0.0]
             for side in ("left", "right")}
    return lambda side, placement: (placement.rotation @ local[side] + placement.translation)[:2]


class ZmpReference:
    """p_ref(t) (x, y) of the phases, from ``start``."""

    def __init__(self, phases: list[Phase], centre: Centre, start: np.ndarray):
        self.centre = centre
        singles = [phase for phase in phases if phase.single]
        stance_centres = [centre(phase.stance[0], phase.feet[phase.stance[0]]) for phase in singles]
        final = 0.5 * (centre("left", phases[-1].feet["left"]) + centre("right", phases[-1].feet["right"]))
        ends = [t for phase in singles for t in (phase.start, phase.end)]
        self.knot_times = np.array([phases[0].start, *ends, phases[-1].end])
        self.knot_points = np.array([np.asarray(start, dtype=float)[:2],
                                     *[point for point in stance_centres for _ in range(2)], final])

    @property
    def end(self) -> float:
        return float(self.knot_times[-1])

    def __call__(self, times) -> np.ndarray:
        """(len(times), 2) reference points (held at the ends)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        knots = self.knot_times
        index = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(knots) - 2)
        span = knots[index + 1] - knots[index]
        s = quintic(np.where(span > 0, (times - knots[index]) / np.where(span > 0, span, 1.0), 1.0))
        start, end = self.knot_points[index], self.knot_points[index + 1]
        return start + s[:, None] * (end - start)
