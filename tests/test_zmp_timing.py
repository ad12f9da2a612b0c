"""A quasi-static motion timed to stay quasi-static (:mod:`wbik.motion.walking.zmp_timing`): after the
slowing, the multibody ZMP of the timed motion (recomputed here on a finer grid with
:func:`multibody_zmp`, from configurations placed here on a sole both samples of a piece stand on) stays
within the bound of the CoM's projection; each piece is slowed no more than one grid step beyond what the
bound needs, and a piece within it keeps its duration; bad bounds and timings whose pieces it cannot judge
are refused; a contact time constant MuJoCo cannot keep stable is refused."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.apps.bioloid.behaviours import half_step_sequence
from wbik.apps.bioloid.gait import time_scale_motion
from wbik.errors import InvalidConfigurationError, InvalidSettingError
from wbik.motion.timing import Piece
from wbik.motion.walking import zmp_timing
from wbik.motion.walking.multibody_zmp import actuated_joints, multibody_zmp, trajectory_derivatives
from wbik.motion.walking.physics import Servos, Simulation
from wbik.motion.walking.static_gait import SampledMotion

FINE = 60  # intervals per piece of the independent check (the module uses zmp_timing.GRID)


@pytest.fixture(scope="module")
def half_steps():
    robot = wbik.load("bioloid")
    return robot, half_step_sequence(robot, ["WalkSR1", "WalkSR2"]).motion


def _placed(robot, anchor: np.ndarray, sole: str, joints: np.ndarray, columns: list[int]) -> np.ndarray:
    """The joints set and the base moved so that ``sole`` keeps its pose in ``anchor`` (written here
    apart from the module's)."""
    q = anchor.copy()
    q[columns] = joints
    move = robot.frame_placement(anchor, sole) * robot.frame_placement(q, sole).inverse()
    base = move * pin.SE3(pin.Quaternion(q[6], *q[3:6]).toRotationMatrix(), q[:3].copy())
    q[:3], q[3:7] = base.translation, pin.Quaternion(base.rotation).coeffs()
    return q


def _shift(robot, motion, timed, piece, intervals: int, skip: int = 2) -> float:
    """The largest |ZMP - CoM_xy| over the points of ``piece`` as ``timed`` times it, ``skip`` left out at
    each end (where the differences are one-sided or the piece rests), standing on a sole both of its
    samples list."""
    model = robot.model
    columns = [model.joints[j].idx_q for j in actuated_joints(model)]
    sole = sorted(set(motion.support[piece.first]) & set(motion.support[piece.last]))[-1]
    times = piece.start + piece.duration * np.linspace(0.0, 1.0, intervals + 1)
    joints, _, _ = timed.evaluate(times)
    qs = np.array([_placed(robot, motion.q[piece.last], sole, row, columns) for row in joints])
    velocity, acceleration = trajectory_derivatives(model, qs, piece.duration / intervals)
    ground = robot.frame_placement(qs[0], sole).translation[2]
    zmp = multibody_zmp(model, qs, velocity, acceleration, ground)
    com = np.array([robot.center_of_mass(q)[:2] for q in qs])
    return float(np.max(np.linalg.norm(zmp[skip:-skip] - com[skip:-skip], axis=1)))


@pytest.mark.parametrize(("rpm", "bound"), [(40.0, 0.004), (2.0, 0.002)])
def test_slowed_pieces_keep_the_zmp_near_the_com(half_steps, rpm, bound):
    robot, motion = half_steps
    fast = time_scale_motion(motion, rpm)
    slow = time_scale_motion(motion, rpm, zmp_shift_max=bound)
    assert slow.duration > fast.duration
    assert np.all(np.diff(slow.sample_times) >= 0)
    slowed = kept = 0
    for before, after in zip(fast.timed.pieces, slow.timed.pieces, strict=True):
        assert after.duration >= before.duration
        if after.duration == 0:
            continue
        shift = _shift(robot, motion, slow.timed, after, FINE)
        assert shift <= bound * 1.03, (after.first, shift)  # a finer grid than the module's: 3 % spare
        if after.duration > before.duration:
            slowed += 1
            # one grid step faster breaks the bound: the slowing is the least of its grid
            quicker = one_piece(slow.timed, after, after.duration / zmp_timing.GROWTH)
            assert _shift(robot, motion, quicker, quicker.pieces[0], zmp_timing.GRID, 1) > bound
        else:
            kept += 1
            assert _shift(robot, motion, fast.timed, before, zmp_timing.GRID, 1) <= bound
    assert slowed > 0 and (kept > 0 or rpm > 2)  # slower servos leave some pieces as they were
    # the joints pass the same samples: only the clock changed
    q_fast, _, _ = fast.timed.evaluate(fast.sample_times)
    q_slow, _, _ = slow.timed.evaluate(slow.sample_times)
    np.testing.assert_allclose(q_slow, q_fast, atol=1e-12)


def one_piece(timed, piece, duration: float):
    """``timed`` reduced to ``piece`` alone, lasting ``duration``."""
    moved = Piece(piece.first, piece.last, 0.0, duration, piece.spline)
    knots = np.array(timed.knot_times, dtype=float)
    span = slice(piece.first, piece.last + 1)
    knots[span] = (knots[span] - piece.start) * duration / piece.duration
    return replace(timed, pieces=[moved], knot_times=knots, duration=duration)


@pytest.mark.parametrize(("mode", "law", "message"), [("waypoint", "quintic", "mode 'segment'"),
                                                       ("global", "quintic", "mode 'segment'"),
                                                       ("segment", "linear", "bounded acceleration")])
def test_a_timing_whose_pieces_it_cannot_judge_is_refused(half_steps, mode, law, message):
    robot, motion = half_steps
    with pytest.raises(InvalidConfigurationError, match=message):
        time_scale_motion(motion, 40.0, law, mode, zmp_shift_max=0.005)


@pytest.mark.parametrize("bound", [0.0, -0.01, math.nan])
def test_a_bound_that_is_not_positive_is_refused(half_steps, bound):
    robot, motion = half_steps
    with pytest.raises(InvalidConfigurationError, match="must be positive"):
        time_scale_motion(motion, 40.0, zmp_shift_max=bound)


def test_a_contact_time_constant_under_two_timesteps_is_refused_and_one_above_is_applied():
    robot = wbik.load("bioloid")
    servos = Servos(37.05, damping=0.243, torque_limit=1.5, armature=1e-3)
    with pytest.raises(InvalidSettingError, match="under two physics timesteps"):
        Simulation(robot, servos, robot.nominal, timestep=0.001, contact_time_constant=0.0015)
    sim = Simulation(robot, servos, robot.nominal, timestep=0.001, contact_time_constant=0.004)
    assert np.all(sim.model.geom_solref[:, 0] == 0.004)
    default = Simulation(robot, servos, robot.nominal, timestep=0.001)
    assert np.all(default.model.geom_solref[:, 0] == 0.02)  # MuJoCo's own


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_slowing_moves_by_at_most_one_grid_step_under_rounding_noise(half_steps, seed):
    """Joints moved by 1e-12 of their value (another CPU's rounding) slow each piece by the same factor, or
    by the next one of the grid where the piece sits on the bound: never by more."""
    robot, motion = half_steps
    rng = np.random.default_rng(seed)
    noisy_q = motion.q * (1.0 + 1e-12 * rng.standard_normal(motion.q.shape))
    noisy = SampledMotion(motion.name, robot, noisy_q, motion.phase, motion.phase_names, motion.support)
    factors = []
    for sampled in (motion, noisy):
        fast, slow = time_scale_motion(sampled, 40.0), time_scale_motion(sampled, 40.0, zmp_shift_max=0.004)
        pairs = zip(fast.timed.pieces, slow.timed.pieces, strict=True)
        factors.append(np.array([after.duration / before.duration if before.duration > 0 else 1.0
                                 for before, after in pairs]))
    steps = np.abs(np.log(factors[1] / factors[0])) / math.log(zmp_timing.GROWTH)
    assert np.all(steps <= 1.0 + 1e-6)
