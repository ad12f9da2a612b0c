"""Moves of a riveting cycle: rest-to-rest joint paths timed under the joint limits (or stretched to a
fixed duration), dwells, and the samples at which the run checks them."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache

import numpy as np

from wbik.motion.path import JointPath
from wbik.motion.timing import Piece, TimedPath, time_scale
from wbik.robot import Chain
from wbik.solvers.analytic.structure import chain_lines, poe_fk


@dataclass
class Move:
    """A timed joint path (from ``offset`` s on ``timed``, ``reverse``: backward) or a dwell at ``hold``."""

    name: str
    duration: float
    timed: TimedPath | None = None
    hold: np.ndarray | None = None
    fine: bool = False  # sample finely (the tool near or in the hole)
    info: dict | None = None
    offset: float = 0.0
    reverse: bool = False

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Joint rows at local times t in [0, duration]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return (np.repeat(self.hold[None], len(t), axis=0) if self.timed is None
                else self.timed.evaluate(self.local_times(t))[0])

    def local_times(self, t: np.ndarray) -> np.ndarray:
        """Times on ``timed`` of the move's local times t."""
        local = np.atleast_1d(np.asarray(t, dtype=float)) + self.offset
        if self.reverse:
            local = self.timed.duration - local
        return np.clip(local, 0.0, self.timed.duration)

    @property
    def start(self) -> np.ndarray:
        return self.evaluate(0.0)[0]

    @property
    def end(self) -> np.ndarray:
        return self.evaluate(self.duration)[0]


@dataclass(frozen=True)
class Limits:
    """Joint velocity (rad/s, per joint) and acceleration (rad/s^2) limits and the time law."""

    velocity: np.ndarray
    acceleration: float
    law: str = "quintic"


def joint_path_through(chain: Chain, knots: np.ndarray) -> JointPath:
    """A JointPath through ``knots`` (K, n) parameterised by normalised joint-space arc length."""
    knots = np.asarray(knots, dtype=float)
    knots = knots[np.r_[True, np.linalg.norm(np.diff(knots, axis=0), axis=1) > 1e-12]]
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
    s = lengths / lengths[-1] if lengths[-1] > 0 else np.linspace(0.0, 1.0, len(knots))
    return JointPath(chain, s, knots, info={"kind": "riveting"})


def timed_move(name: str, chain: Chain, knots: np.ndarray, limits: Limits, duration: float | None = None,
               fine: bool = False) -> Move:
    """A rest-to-rest move through ``knots``: minimum time under ``limits``, or ``duration`` if longer."""
    knots = np.asarray(knots, dtype=float)
    if np.max(np.abs(knots[-1] - knots[0])) < 1e-12 and len(knots) <= 2:
        return Move(name, 0.0, hold=knots[0].copy(), fine=fine)
    timed = time_scale(joint_path_through(chain, knots), limits.law, velocity_limit=limits.velocity,
                       acceleration_limit=limits.acceleration, mode="global")
    minimum = timed.duration
    if duration is not None and duration > timed.duration:
        factor = duration / timed.duration
        pieces = [Piece(piece.first, piece.last, piece.start * factor, piece.duration * factor, piece.spline)
                  for piece in timed.pieces]
        timed = replace(timed, pieces=pieces, knot_times=timed.knot_times * factor, duration=duration)
    return Move(name, timed.duration, timed=timed, fine=fine, info={"minimum_duration_s": minimum})


def split(whole: Move, at: float, names: tuple[str, str], fine: tuple[bool, bool]) -> list[Move]:
    """One timed motion cut at time ``at`` (s) into two moves that follow each other without a stop."""
    timed, info, at = whole.timed, whole.info, float(at)
    return [Move(names[0], at, timed=timed, fine=fine[0], info=info),
            Move(names[1], float(timed.duration - at), timed=timed, fine=fine[1], info=info, offset=at)]


def backward(move: Move, name: str, fine: bool = False) -> Move:
    """``move`` run backward (its path from end to start, same duration)."""
    return Move(name, move.duration, timed=move.timed, fine=fine, info=move.info,
                offset=float(move.timed.duration - move.offset - move.duration), reverse=not move.reverse)


def dwell(name: str, q: np.ndarray, duration: float) -> Move:
    return Move(name, float(duration), hold=np.asarray(q, dtype=float).copy())


def samples(move: Move, chain: Chain, step: float = 0.002, angle_step: float = 0.01,
            fine_step: float = 0.0002, resolution: float = 5e-4) -> tuple[np.ndarray, np.ndarray]:
    """(local times, joint rows) at which to check a move: on a ``resolution`` s grid, the point before the
    tcp has moved ``step`` m (``fine_step`` if fine) or a joint ``angle_step`` rad, and the end points."""
    if move.timed is None or move.duration <= 0:
        return np.array([0.0]), move.evaluate(0.0)
    count = max(int(np.ceil(move.duration / resolution)), 2) + 1
    times = np.linspace(0.0, move.duration, count)
    rows = move.evaluate(times)
    near_tips = poe_fk(chain_lines(chain), rows)[0]
    limit = fine_step if move.fine else step

    @cache
    def tip(index: int) -> np.ndarray:
        return chain.fk(rows[index]).translation

    def moved(index: int, last: int) -> bool:
        return bool(np.linalg.norm(tip(index) - tip(last)) >= limit
                    or np.max(np.abs(rows[index] - rows[last])) >= angle_step)

    kept, index, width = [0], 1, 64  # the window searched: twice the last gap
    while index < count:
        last, ahead = kept[-1], slice(index, min(index + width, count))
        turned = np.max(np.abs(rows[ahead] - rows[last]), axis=1) >= angle_step
        maybe = turned | (np.linalg.norm(near_tips[ahead] - near_tips[last], axis=1) >= limit - 1e-9)
        found = next((i for i in np.flatnonzero(maybe) + index if moved(i, last)), None)
        if found is None:
            index, width = ahead.stop, 2 * width
            continue
        kept.append(found - 1 if found - 1 > last else found)
        index, width = found + 1, 2 * (found - last) + 16
    kept = np.unique([*kept, count - 1])
    return times[kept], rows[kept]
