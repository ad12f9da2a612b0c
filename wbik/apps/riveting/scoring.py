"""The EuRoC scoring of the riveting task, Table 5 of the thesis, 30 points:

| Sub-task                      | Interval                                  | Points         |
|-------------------------------|-------------------------------------------|----------------|
| mean hole-localisation error  | > 5 mm or 5 deg                           | 0              |
|                               | between 1.5 and 5 mm, or 3 to 5 deg       | 2              |
|                               | between 0.3 and 1.5 mm, or 1 to 3 deg     | 5              |
|                               | < 0.3 mm or 1 deg                         | 10             |
| rivets done correctly (300 s) | 0-4 / 5-9 / 10-14 / 15 or more            | 0 / 2 / 5 / 10 |
| robot-workpiece collisions    | > 0 / 0                                   | 0 / 10         |

Our reading (the seed is ambiguous, ur5-riveting.md 2.4): the localisation score is the worse of the
position and the angle bands, a boundary value goes to the worse band ("< 0.3 mm" is strict, only "> 5"
scores 0), and no rivet scores 0. A rivet's localisation error (our definition, 7.3): the tcp at
trigger_rivet against the true hole's inserted pose, position (m) and tool-axis angle (rad).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

POSITION_BANDS_MM = (0.3, 1.5, 5.0)
ANGLE_BANDS_DEG = (1.0, 3.0, 5.0)
LOCALISATION_POINTS = (10, 5, 2, 0)
RIVET_BANDS = ((15, 10), (10, 5), (5, 2), (0, 0))  # (at least this many rivets, points), best first
MAXIMUM = 30


def band(value: float, bounds: Sequence[float]) -> int:
    """0 if value < bounds[0]; k if bounds[k-1] <= value <= bounds[k]; len(bounds) above the last."""
    if value < bounds[0]:
        return 0
    return next((index for index in range(1, len(bounds)) if value <= bounds[index]), len(bounds))


def localisation_points(position_error_mm: float | None, angle_error_deg: float | None) -> int:
    """Points for the mean localisation error: the worse of the position and the angle band."""
    if position_error_mm is None or angle_error_deg is None \
            or not (np.isfinite(position_error_mm) and np.isfinite(angle_error_deg)):
        return 0
    return LOCALISATION_POINTS[max(band(position_error_mm, POSITION_BANDS_MM),
                                   band(angle_error_deg, ANGLE_BANDS_DEG))]


def rivet_points(rivets: int) -> int:
    return next((points for minimum, points in RIVET_BANDS if rivets >= minimum), 0)


@dataclass(frozen=True)
class Score:
    localisation: int
    rivets: int
    collisions: int

    @property
    def total(self) -> int:
        return self.localisation + self.rivets + self.collisions

    def as_dict(self) -> dict:
        return {**asdict(self), "total": self.total, "maximum": MAXIMUM}


def score(position_errors_m: Sequence[float], angle_errors_rad: Sequence[float], rivets: int,
          collisions: int) -> Score:
    """Table 5 from the per-rivet localisation errors (SI units), the rivet count and the collisions."""
    localisation = 0
    if len(position_errors_m):
        localisation = localisation_points(float(np.mean(position_errors_m)) * 1e3,
                                           float(np.degrees(np.mean(angle_errors_rad))))
    return Score(localisation, rivet_points(int(rivets)), 10 if int(collisions) == 0 else 0)
