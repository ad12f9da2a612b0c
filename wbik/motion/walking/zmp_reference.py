"""The ZMP reference of a walk: a point inside the support at every instant.

Piecewise over the support phases (:mod:`wbik.motion.walking.timeline`), moving between two points
with the quintic s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (its velocity and acceleration zero at both
ends, so the pendulum's CoM is not asked for a jerk it cannot have):

- single support: the centre of the stance sole (the centroid of its contact points, ``robot.soles``,
  optionally moved ``forward`` along the sole);
- double support between two single supports: from the centre of the sole that stood to the centre
  of the sole that will stand (a segment inside the hull of the two soles);
- the first double support: from ``start`` (the CoM's ground projection when the walk begins, so the
  reference starts where the standing robot's ZMP is) to the first stance sole; the last one: to the
  midpoint of the two soles' centres (``end``, unless given).

After the last phase the reference stays at its final value (the preview controller looks ahead).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from wbik.motion.walking.timeline import Phase

Centre = Callable[[str, pin.SE3], np.ndarray]
"""(side, sole placement) -> the sole's centre on the ground (x, y)."""


def sole_centres(robot, feet, forward: float = 0.0) -> Centre:
    """The ZMP target of a sole at a placement (x, y): its contact points' centroid, ``forward`` m
    ahead along the sole's x axis."""
    local = {side: np.asarray(robot.soles[feet.frame(side)], dtype=float).mean(axis=0) + [forward, 0.0, 0.0]
             for side in ("left", "right")}
    return lambda side, placement: (placement.rotation @ local[side] + placement.translation)[:2]


class ZmpReference:
    """p_ref(t) (x, y) of the phases; see the module docstring."""

    def __init__(self, phases: list[Phase], centre: Centre, start: np.ndarray, end: np.ndarray | None = None):
        self.phases = phases
        knots_t, knots_p = [], []
        singles = [phase for phase in phases if phase.single]
        stance_centres = [centre(phase.stance[0], phase.feet[phase.stance[0]]) for phase in singles]
        last = phases[-1].feet
        final = (0.5 * (centre("left", last["left"]) + centre("right", last["right"])) if end is None
                 else np.asarray(end, dtype=float)[:2])
        knots_t.append(phases[0].start)
        knots_p.append(np.asarray(start, dtype=float)[:2])
        for index, phase in enumerate(singles):
            knots_t += [phase.start, phase.end]
            knots_p += [stance_centres[index], stance_centres[index]]
        knots_t.append(phases[-1].end)
        knots_p.append(final)
        self.knot_times = np.array(knots_t)
        self.knot_points = np.array(knots_p)

    @property
    def end(self) -> float:
        return float(self.knot_times[-1])

    def __call__(self, times) -> np.ndarray:
        """(len(times), 2) reference points (held at the ends)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        knots = self.knot_times
        index = np.clip(np.searchsorted(knots, times, side="right") - 1, 0, len(knots) - 2)
        span = knots[index + 1] - knots[index]
        tau = np.clip((times - knots[index]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
        tau = np.where(span > 0, tau, 1.0)
        s = tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau))
        start, end = self.knot_points[index], self.knot_points[index + 1]
        return start + s[:, None] * (end - start)
