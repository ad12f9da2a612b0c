"""Time laws s(tau): how a path parameter s in [0, 1] advances with normalised time tau in [0, 1].

A trajectory of duration T follows q(t) = q_path(s(t / T)), so

    dq/dt   = q'(s) s'(tau) / T
    d2q/dt2 = (q''(s) s'(tau)^2 + q'(s) s''(tau)) / T^2

- ``linear``:  s = tau (constant speed, what the seeds used; s' jumps from 0 to 1 at the ends, so
  the acceleration is unbounded there and an acceleration limit cannot be honoured);
- ``cubic``:   s = 3 tau^2 - 2 tau^3 (rest to rest; peak s' = 3/2, peak |s''| = 6 at the ends);
- ``quintic``: s = 10 tau^3 - 15 tau^4 + 6 tau^5, the minimum-jerk law (rest to rest with zero
  acceleration at both ends; peak s' = 15/8 at tau = 1/2, peak |s''| = 10 / sqrt(3) at
  tau = 1/2 -+ sqrt(3) / 6). ``minimum_jerk`` is an alias.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.polynomial import polyder
from numpy.polynomial.polynomial import polyval

from wbik.errors import UnknownNameError


class UnknownTimeLawError(UnknownNameError):
    kind = "time law"


@dataclass(frozen=True)
class TimeLaw:
    """A monotonic polynomial s(tau) = sum_k c_k tau^k with s(0) = 0, s(1) = 1, its derivatives and
    their peaks."""

    name: str
    peak_velocity: float  # max s'(tau) over [0, 1]
    peak_acceleration: float  # max |s''(tau)| over [0, 1]; inf for the linear law
    coefficients: tuple[float, ...]  # c_0, c_1, ... (increasing powers)

    def s(self, tau):
        return polyval(np.clip(tau, 0.0, 1.0), self.coefficients)

    def ds(self, tau):
        """s'(tau); zero outside [0, 1] (the trajectory rests before and after)."""
        return self._derivative(tau, 1)

    def dds(self, tau):
        """s''(tau) (zero for the linear law away from its end points)."""
        return self._derivative(tau, 2)

    def _derivative(self, tau, order: int):
        """d^order s / dtau^order inside [0, 1], zero outside."""
        tau = np.asarray(tau, dtype=float)
        value = polyval(tau, polyder(self.coefficients, order)) + np.zeros_like(tau)
        return np.where((tau >= 0.0) & (tau <= 1.0), value, 0.0)

    def inverse(self, s) -> np.ndarray:
        """tau with s(tau) = s, by bisection (every law is monotonic)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        if self.name == "linear":
            return s.copy()
        low, high = np.zeros_like(s), np.ones_like(s)
        for _ in range(60):
            middle = 0.5 * (low + high)
            below = self.s(middle) < s
            low = np.where(below, middle, low)
            high = np.where(below, high, middle)
        tau = 0.5 * (low + high)
        return np.where(s >= 1.0, 1.0, np.where(s <= 0.0, 0.0, tau))


LAWS: dict[str, TimeLaw] = {
    "linear": TimeLaw("linear", 1.0, math.inf, (0.0, 1.0)),
    "cubic": TimeLaw("cubic", 1.5, 6.0, (0.0, 0.0, 3.0, -2.0)),
    "quintic": TimeLaw("quintic", 15.0 / 8.0, 10.0 / math.sqrt(3.0), (0.0, 0.0, 0.0, 10.0, -15.0, 6.0)),
}
ALIASES = {"minimum_jerk": "quintic", "min_jerk": "quintic"}


def time_law(name: str | TimeLaw) -> TimeLaw:
    """The time law called ``name`` (linear, cubic, quintic / minimum_jerk)."""
    if isinstance(name, TimeLaw):
        return name
    key = ALIASES.get(str(name).lower(), str(name).lower())
    if key not in LAWS:
        raise UnknownTimeLawError(str(name), [*LAWS, *ALIASES])
    return LAWS[key]
