"""Moves of a riveting cycle: timed joint paths (wbik.motion) and dwells, with dense sampling.

Every move is rest to rest: a joint path (knots) timed by :func:`wbik.motion.time_scale` with the
quintic (minimum-jerk) law under the UR5's joint velocity limits (URDF: 3.15 rad/s for the first
three joints, 3.2 rad/s for the wrists) and our acceleration limit. A planner may ask for a
longer, fixed duration (the thesis's fixed trajectory times); the limits then hold a fortiori.
A dwell holds one configuration (load_rivet, trigger_rivet, the thesis's sleep).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import replace

import numpy as np

from wbik.motion.path import JointPath
from wbik.motion.timing import Piece
from wbik.motion.timing import TimedPath
from wbik.motion.timing import time_scale
from wbik.robot import Chain


@dataclass
class Move:
    """One step of a cycle: a timed joint path, or a dwell at ``hold`` for ``duration`` seconds."""

    name: str
    duration: float
    timed: TimedPath | None = None
    hold: np.ndarray | None = None
    fine: bool = False  # sample finely (the tool near or in the hole)
    info: dict | None = None
    offset: float = 0.0
    """Where this move starts on ``timed`` (s): a part of one blended motion (no stop between parts)."""
    reverse: bool = False
    """Run ``timed`` backward (the same path home; time laws are symmetric, so the limits still hold)."""

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Joint rows at local times t in [0, duration]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.timed is None:
            return np.repeat(self.hold[None], len(t), axis=0)
        return self.timed.evaluate(self.local_times(t))[0]

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


def stretch(timed: TimedPath, duration: float) -> TimedPath:
    """The same path and law, slowed down uniformly to last ``duration`` (>= its own duration)."""
    factor = duration / timed.duration
    pieces = [Piece(p.first, p.last, p.start * factor, p.duration * factor, p.spline) for p in timed.pieces]
    return replace(timed, pieces=pieces, knot_times=timed.knot_times * factor, duration=duration)


def joint_path_through(chain: Chain, knots: np.ndarray) -> JointPath:
    """A JointPath through ``knots`` (K, n) parameterised by normalised joint-space arc length."""
    knots = np.asarray(knots, dtype=float)
    steps = np.linalg.norm(np.diff(knots, axis=0), axis=1)
    keep = np.r_[True, steps > 1e-12]
    knots = knots[keep]
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
    s = lengths / lengths[-1] if lengths[-1] > 0 else np.linspace(0.0, 1.0, len(knots))
    return JointPath(chain, s, knots, info={"kind": "riveting"})


def timed_move(name: str, chain: Chain, knots: np.ndarray, limits: Limits,
               duration: float | None = None, fine: bool = False, info: dict | None = None) -> Move:
    """A rest-to-rest move through ``knots``: minimum time under ``limits``, or ``duration`` if longer."""
    knots = np.asarray(knots, dtype=float)
    if np.max(np.abs(knots[-1] - knots[0])) < 1e-12 and len(knots) <= 2:
        return Move(name, 0.0, hold=knots[0].copy(), fine=fine, info=info)
    timed = time_scale(joint_path_through(chain, knots), limits.law, velocity_limit=limits.velocity,
                       acceleration_limit=limits.acceleration, mode="global")
    minimum = timed.duration
    if duration is not None and duration > timed.duration:
        timed = stretch(timed, duration)
    return Move(name, timed.duration, timed=timed, fine=fine,
                info={**(info or {}), "minimum_duration_s": minimum})


def split(timed_parts: Move, at: float, names: tuple[str, str], fine: tuple[bool, bool]) -> list[Move]:
    """One timed motion cut at time ``at`` (s) into two moves that follow each other without a stop
    (e.g. the approach and the insertion of one blended motion)."""
    timed = timed_parts.timed
    first = Move(names[0], float(at), timed=timed, fine=fine[0], info=timed_parts.info)
    second = Move(names[1], float(timed.duration - at), timed=timed, fine=fine[1], info=timed_parts.info,
                  offset=float(at))
    return [first, second]


def backward(move: Move, name: str, fine: bool = False) -> Move:
    """``move`` run backward (its path from end to start, same duration)."""
    timed = move.timed
    return Move(name, move.duration, timed=timed, fine=fine, info=move.info,
                offset=float(timed.duration - move.offset - move.duration), reverse=not move.reverse)


def dwell(name: str, q: np.ndarray, duration: float) -> Move:
    return Move(name, float(duration), hold=np.asarray(q, dtype=float).copy())


def sample_times(move: Move, chain: Chain, step: float = 0.002, angle_step: float = 0.01,
                 fine_step: float = 0.0002, resolution: float = 5e-4) -> np.ndarray:
    """Local times at which to check a move: consecutive samples at most ``step`` m of tcp motion
    (``fine_step`` for fine moves) and ``angle_step`` rad of any joint apart (end points included).

    The move is first evaluated every ``resolution`` s; when the tcp or a joint has moved by the step
    since the last kept sample, the dense point just before is kept, so no gap between kept samples
    exceeds the step (by more than one dense interval at most).
    """
    if move.timed is None or move.duration <= 0:
        return np.array([0.0])
    count = max(int(np.ceil(move.duration / resolution)), 2) + 1
    times = np.linspace(0.0, move.duration, count)
    rows = move.evaluate(times)
    tips = np.array([chain.fk(q).translation for q in rows])
    limit = fine_step if move.fine else step
    kept = [0]
    for index in range(1, count):
        last = kept[-1]
        if (np.linalg.norm(tips[index] - tips[last]) >= limit
                or np.max(np.abs(rows[index] - rows[last])) >= angle_step):
            kept.append(index - 1 if index - 1 > last else index)
    if kept[-1] != count - 1:
        kept.append(count - 1)
    return times[np.unique(kept)]
