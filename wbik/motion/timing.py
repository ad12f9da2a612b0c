"""Time scaling: the shortest timing of a joint path under joint velocity (and acceleration) limits.

Pieces from rest to rest (``mode``: ``global`` one, ``waypoint`` one per waypoint segment, ``segment`` one
per knot interval) each follow a time law along a cubic spline q(u), u = s(tau), and last
T = max(max |q'_j s'| / v_j, sqrt(max |q''_j s'^2 + q'_j s''| / a_j)) over tau (closed form for two knots,
else a dense grid refined by a bounded scalar search)."""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from wbik.errors import InvalidConfigurationError, UnsupportedError
from wbik.motion.path import JointPath
from wbik.motion.profiles import TimeLaw, time_law

RPM = 2.0 * np.pi / 60.0  # rad/s per rpm

GRID_POINTS = 4001  # the dense tau grid of a multi-knot piece
MODES = ("global", "waypoint", "segment")


def _limit_vector(value, count: int, what: str) -> np.ndarray | None:
    if value is None:
        return None
    array = np.broadcast_to(np.asarray(value, dtype=float), (count,)).copy()
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise InvalidConfigurationError(f"{what} must be positive and finite per joint, got {array.tolist()}")
    return array


@dataclass
class Piece:
    """Knots first..last passed by one time law from rest to rest, starting at ``start`` for ``duration``."""

    first: int
    last: int
    start: float
    duration: float
    spline: CubicSpline


@dataclass
class TimedPath:
    """A joint path with a timing (s)."""

    path: JointPath
    law: TimeLaw
    mode: str
    pieces: list[Piece]
    knot_times: np.ndarray  # (K,) the time at which each knot is passed
    duration: float
    velocity_limit: np.ndarray
    acceleration_limit: np.ndarray | None = None

    def _locate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        starts = np.array([piece.start for piece in self.pieces])
        index = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        durations = np.array([piece.duration for piece in self.pieces])[index]
        tau = np.where(durations > 0, (t - starts[index]) / np.where(durations > 0, durations, 1.0), 1.0)
        return index, np.clip(tau, 0.0, 1.0)

    def parameter(self, t) -> np.ndarray:
        """Path parameter s at times t."""
        t = np.atleast_1d(np.clip(np.asarray(t, dtype=float), 0.0, self.duration))
        index, tau = self._locate(t)
        s = self.path.s
        first = np.array([s[piece.first] for piece in self.pieces])[index]
        last = np.array([s[piece.last] for piece in self.pieces])[index]
        return first + (last - first) * self.law.s(tau)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, dq/dt, d2q/dt2) at times t, each of shape (len(t), n)."""
        t = np.atleast_1d(np.clip(np.asarray(t, dtype=float), 0.0, self.duration))
        index, tau = self._locate(t)
        count = self.path.q.shape[1]
        q, velocity, acceleration = (np.zeros((len(t), count)) for _ in range(3))
        for number in np.unique(index):  # only the pieces the times fall in
            piece, mask = self.pieces[number], index == number
            local = tau[mask]
            u, du, ddu = self.law.s(local), self.law.ds(local), self.law.dds(local)
            first, second = piece.spline(u, 1), piece.spline(u, 2)
            q[mask] = piece.spline(u)
            if piece.duration > 0:
                velocity[mask] = first * (du / piece.duration)[:, None]
                acceleration[mask] = (second * (du**2)[:, None] + first * ddu[:, None]) / piece.duration**2
        return q, velocity, acceleration


def _peak(ratio, grid: np.ndarray) -> float:
    values = ratio(grid)
    best = float(values.max())
    for cell in np.argsort(values)[-8:]:
        low, high = grid[max(cell - 1, 0)], grid[min(cell + 1, len(grid) - 1)]
        found = minimize_scalar(lambda x: -float(ratio(np.array([x]))[0]), bounds=(low, high),
                                method="bounded", options={"xatol": 1e-12})
        best = max(best, -float(found.fun))
    return best


def _piece_duration(spline: CubicSpline, knots: int, law: TimeLaw, velocity: np.ndarray,
                    acceleration: np.ndarray | None) -> float:
    if knots == 2:  # a straight line: closed form
        delta = np.abs(spline(1.0) - spline(0.0))
        duration = float(np.max(delta * law.peak_velocity / velocity))
        if acceleration is not None:
            duration = max(duration, float(np.max(np.sqrt(delta * law.peak_acceleration / acceleration))))
        return duration

    def velocity_ratio(tau: np.ndarray) -> np.ndarray:
        return np.max(np.abs(spline(law.s(tau), 1)) * law.ds(tau)[..., None] / velocity, axis=-1)

    def acceleration_ratio(tau: np.ndarray) -> np.ndarray:
        u = law.s(tau)
        value = spline(u, 2) * (law.ds(tau) ** 2)[..., None] + spline(u, 1) * law.dds(tau)[..., None]
        return np.max(np.abs(value) / acceleration, axis=-1)

    grid = np.union1d(np.linspace(0.0, 1.0, GRID_POINTS), law.inverse(spline.x))
    duration = _peak(velocity_ratio, grid)
    if acceleration is not None:
        duration = max(duration, float(np.sqrt(_peak(acceleration_ratio, grid))))
    return duration


def time_scale(path: JointPath, law: str | TimeLaw = "quintic", velocity_limit=None,
               acceleration_limit=None, mode: str = "global") -> TimedPath:
    """The shortest timing of ``path``; limits per joint or one for all (rad/s, rad/s^2 or m/s, m/s^2;
    ``velocity_limit`` defaults to the URDF's)."""
    law = time_law(law)
    count = path.chain.nq
    velocity = _limit_vector(path.chain.velocity_limit if velocity_limit is None else velocity_limit, count,
                             "velocity_limit")
    acceleration = _limit_vector(acceleration_limit, count, "acceleration_limit")
    if acceleration is not None and not np.isfinite(law.peak_acceleration):
        raise UnsupportedError("the linear time law jumps in speed at its ends (unbounded acceleration); "
                               "use 'cubic' or 'quintic' with an acceleration limit")
    if mode not in MODES:
        raise InvalidConfigurationError(f"mode must be one of {MODES}, got {mode!r}")
    last = len(path.s) - 1
    if last < 1:
        raise InvalidConfigurationError("a path needs at least two knots to be timed")
    breaks = {"global": [0, last], "segment": list(range(last + 1)),
              "waypoint": sorted({0, last, *[k for k in path.waypoint_knots if 0 < k < last]})}[mode]
    pieces, knot_times, clock = [], np.zeros(last + 1), 0.0
    for first, end in zip(breaks[:-1], breaks[1:], strict=True):
        s = path.s[first:end + 1]
        spline = CubicSpline((s - s[0]) / (s[-1] - s[0]), path.q[first:end + 1], axis=0, bc_type="not-a-knot")
        duration = _piece_duration(spline, end - first + 1, law, velocity, acceleration)
        knot_times[first:end + 1] = clock + duration * law.inverse(spline.x)
        pieces.append(Piece(first, end, clock, duration, spline))
        clock += duration
    if clock <= 0:
        raise InvalidConfigurationError("the path does not move: every knot is the same configuration")
    return TimedPath(path, law, mode, pieces, knot_times, clock, velocity, acceleration)


def time_samples(joints: np.ndarray, velocity_limit, law: str = "quintic", mode: str = "segment",
                 waypoint_knots=()) -> TimedPath:
    """The shortest timing through joint samples (K, n), s along their joint-space polyline (a still
    sample gets its own s)."""
    steps = np.maximum(np.linalg.norm(np.diff(joints, axis=0), axis=1), 1e-9)
    s = np.r_[0.0, np.cumsum(steps)] / np.sum(steps)
    path = JointPath(SimpleNamespace(nq=joints.shape[1]), s, joints, waypoint_knots=list(waypoint_knots))
    return time_scale(path, law, velocity_limit=velocity_limit, mode=mode)
