"""Time laws s(tau): how a path parameter s in [0, 1] advances with normalised time tau in [0, 1].

A trajectory of duration T follows q(t) = q_path(s(t / T)), so dq/dt = q'(s) s' / T and
d2q/dt2 = (q''(s) s'^2 + q'(s) s'') / T^2.

- ``linear``:  s = tau (s' jumps at the ends: unbounded acceleration, no acceleration limit);
- ``cubic``:   s = 3 tau^2 - 2 tau^3 (rest to rest; peak s' = 3/2, peak |s''| = 6);
- ``quintic`` (alias ``minimum_jerk``): s = 10 tau^3 - 15 tau^4 + 6 tau^5 (zero acceleration at
  both ends too; peak s' = 15/8, peak |s''| = 10 / sqrt(3))."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.polynomial import polyder, polyval

from wbik.errors import UnknownNameError


class UnknownTimeLawError(UnknownNameError):
    kind = "time law"


@dataclass(frozen=True)
class TimeLaw:
    """A monotonic polynomial s(tau) = sum_k c_k tau^k from s(0) = 0 to s(1) = 1."""

    name: str
    peak_velocity: float  # max s'
    peak_acceleration: float  # max |s''|; inf for the linear law
    coefficients: tuple[float, ...]  # c_0, c_1, ... (increasing powers)

    def s(self, tau):
        return polyval(np.clip(tau, 0.0, 1.0), self.coefficients)

    def ds(self, tau):
        """s'(tau); zero outside [0, 1] (the trajectory rests before and after)."""
        return self._derivative(tau, 1)

    def dds(self, tau):
        """s''(tau); zero outside [0, 1]."""
        return self._derivative(tau, 2)

    def _derivative(self, tau, order: int):
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
            low, high = np.where(below, middle, low), np.where(below, high, middle)
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
