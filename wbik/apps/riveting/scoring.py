"""The EuRoC scoring of the riveting task (the thesis's Table 5, 30 points): a mean localisation error under
0.3 mm and 1 deg 10, to 1.5 mm / 3 deg 5, to 5 mm / 5 deg 2, else 0; 15, 10 or 5 rivets in 300 s 10, 5 or 2;
no collision 10. Our reading (ur5-riveting.md 2.4): the worse of the two bands, a boundary value in the worse
band, no rivet no localisation points; a rivet's error is the tcp at trigger_rivet against the true hole's
inserted pose."""

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
    return 0 if value < bounds[0] else next(
        (index for index in range(1, len(bounds)) if value <= bounds[index]), len(bounds))


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
