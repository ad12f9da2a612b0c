"""A quasi-static motion timed so that it stays quasi-static: every rest-to-rest piece of a sampled motion's
timing is slowed until the multibody ZMP stays within ``shift_max`` of the CoM's ground projection.

Slowing a rest-to-rest piece by a factor k keeps its path and divides every velocity by k and every
acceleration (q'' and the q'^2 terms alike) by k^2, so the centroidal wrench is f = -m g + F / k^2,
n = N / k^2 (F, N: the rates of linear and angular momentum about the CoM at k = 1). The ZMP's shift
from the CoM's projection is then ((h F_x + N_y), (h F_y - N_x)) / (k^2 (m g + F_z / k^2)), h the CoM's
height over the stance sole: each piece gets the least k of a geometric grid keeping it within
``shift_max`` (and the ground's push above a fifth of the weight) at every grid point of the piece. The
pieces must each join two samples (timing mode ``segment``), under a law with bounded acceleration.

The floating base between samples is where the stance sole (the sole the two samples stand on) keeps its
pose, as the servos would carry the body."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import pinocchio as pin

from wbik.errors import InvalidConfigurationError
from wbik.motion.timing import Piece, TimedPath
from wbik.motion.walking.footsteps import placed_on
from wbik.motion.walking.multibody_zmp import trajectory_derivatives
from wbik.robot import Robot

GRID = 24  # intervals of the time grid on which a piece's ZMP is checked
GROWTH = 1.02  # the ratio between two slowing factors tried
LEAST_PUSH = 0.2  # the ground's push must stay above this share of the weight
SLOWEST = 1e4  # a piece is never slowed more than this


def stance_support(support: Sequence[Sequence[str]], sample: int) -> tuple[str, ...]:
    """The soles the motion stands on from sample ``sample - 1`` to ``sample``: those both samples list
    (else the sample's own)."""
    both = tuple(sole for sole in support[sample] if sole in support[max(sample - 1, 0)])
    return both or tuple(support[sample])


def stance_sole(support: Sequence[Sequence[str]], sample: int) -> str:
    """One sole of :func:`stance_support` (the first by name): the one that keeps its pose."""
    return sorted(stance_support(support, sample))[0]


def stance_placed(robot: Robot, sampled_q: np.ndarray, sole: str, joints: np.ndarray,
                  columns: Sequence[int]) -> np.ndarray:
    """The configurations (R, nq) with each row of the 1-DOF ``joints`` (R, len(columns)) in ``columns`` of
    q and the floating base placed so that ``sole`` is where it is in ``sampled_q`` (:func:`placed_on`)."""
    wanted = robot.frame_placement(sampled_q, sole)
    rows = np.repeat(sampled_q[None, :], len(joints), axis=0)
    rows[:, list(columns)] = joints
    return np.array([placed_on(robot, q, sole, wanted) for q in rows])


def slowed_for_zmp(robot: Robot, q: np.ndarray, support: Sequence[Sequence[str]], timed: TimedPath,
                   columns: Sequence[int], shift_max: float) -> TimedPath:
    """``timed`` (the 1-DOF joints, in ``columns`` of the samples ``q``) with every rest-to-rest piece
    slowed as the module says; a piece already slow enough keeps its duration."""
    if not shift_max > 0:
        raise InvalidConfigurationError(f"the ZMP shift bound must be positive, got {shift_max}")
    if not robot.has_floating_base:
        raise InvalidConfigurationError(f"{robot.name!r} has no floating base to keep a sole still")
    if any(piece.last - piece.first > 1 for piece in timed.pieces):
        raise InvalidConfigurationError("a ZMP shift bound needs a rest at every sample (timing mode "
                                        f"'segment'), got mode {timed.mode!r}: a longer piece may change its "
                                        "stance sole")
    if not np.isfinite(timed.law.peak_acceleration):
        raise InvalidConfigurationError(f"a ZMP shift bound needs a time law with bounded acceleration "
                                        f"('cubic' or 'quintic'), got {timed.law.name!r}")
    if not len(q) == len(support) == len(timed.knot_times):
        raise InvalidConfigurationError(f"{len(q)} samples, {len(support)} supports and "
                                        f"{len(timed.knot_times)} timed knots: one of each per sample")
    model, data = robot.model, robot.model.createData()
    weight = pin.computeTotalMass(model) * float(np.linalg.norm(model.gravity.linear))
    pieces, knot_times, clock = [], np.array(timed.knot_times, dtype=float), 0.0
    for piece in timed.pieces:
        factor = 1.0
        if piece.duration > 0:
            factor = _slowing(robot, q, support, timed, piece, columns, shift_max, weight, data)
        duration = piece.duration * factor
        span = slice(piece.first, piece.last + 1)
        knot_times[span] = clock + (timed.knot_times[span] - piece.start) * factor
        pieces.append(Piece(piece.first, piece.last, clock, duration, piece.spline))
        clock += duration
    return replace(timed, pieces=pieces, knot_times=knot_times, duration=clock)


def _slowing(robot: Robot, q: np.ndarray, support, timed: TimedPath, piece: Piece, columns, shift_max: float,
             weight: float, data: pin.Data) -> float:
    """The least factor of the grid 1, GROWTH, GROWTH^2, ... keeping the piece's ZMP within ``shift_max``."""
    model = robot.model
    sole = stance_sole(support, piece.last)
    times = piece.start + piece.duration * np.linspace(0.0, 1.0, GRID + 1)
    joints, _, _ = timed.evaluate(times)
    configurations = stance_placed(robot, q[piece.last], sole, joints, columns)
    velocity, acceleration = trajectory_derivatives(model, configurations, piece.duration / GRID)
    pin.framesForwardKinematics(model, data, configurations[0])
    ground = data.oMf[robot.frame_id(sole)].translation[2]
    rates = []
    for k in range(1, GRID):  # the ends rest: their one-sided differences are left out
        pin.computeCentroidalMomentumTimeVariation(model, data, configurations[k], velocity[k],
                                                   acceleration[k])
        rates.append((*data.dhg.linear, *data.dhg.angular, data.com[0][2] - ground))
    linear_x, linear_y, linear_z, angular_x, angular_y, _, height = np.array(rates).T  # m c'', dL/dt
    if not np.all(np.isfinite(rates)):
        raise InvalidConfigurationError(f"the motion's momentum is not finite between samples {piece.first} "
                                        f"and {piece.last}")
    factor = 1.0
    while factor < SLOWEST:
        squared = factor * factor
        push = weight + linear_z / squared
        if np.all(push > LEAST_PUSH * weight):
            shift = np.hypot(height * linear_x + angular_y, height * linear_y - angular_x) / (squared * push)
            if np.max(shift) <= shift_max:
                return factor
        factor *= GROWTH
    raise InvalidConfigurationError(f"samples {piece.first} to {piece.last} keep the ZMP {shift_max} m from "
                                    f"the CoM only slowed over {SLOWEST:g} times: is the bound too small?")
