"""The one wrap rule of the geometry kernel, wrap_to_pi: a - 2 pi k in (-pi, pi].

Checked against independent arithmetic (math.remainder, exact multiples of pi), at the boundary and
under tiny relative noise around it, where a different rounding must not give a different turn: a
value near +-pi may come back as either end, but always as the same angle modulo 2 pi and within the
interval. The Bioloid swing path's yaw, which uses the rule, turns the short way round.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from wbik.apps.bioloid.step_wholebody import sole_path
from wbik.geometry import TWO_PI, wrap_to_pi


def test_the_boundary_belongs_to_plus_pi():
    assert float(wrap_to_pi(math.pi)) == math.pi
    assert float(wrap_to_pi(-math.pi)) == math.pi
    assert float(wrap_to_pi(3.0 * math.pi)) == math.pi
    assert float(wrap_to_pi(0.0)) == 0.0
    assert np.array_equal(wrap_to_pi(np.array([-math.pi, math.pi])), [math.pi, math.pi])


@settings(max_examples=300, deadline=None)
@given(st.floats(-50.0, 50.0, allow_nan=False))
def test_same_angle_inside_the_interval(angle):
    wrapped = float(wrap_to_pi(angle))
    assert -math.pi < wrapped <= math.pi
    # the same angle: differs from math.remainder's answer by 0 or a whole turn (at the boundary)
    reference = math.remainder(angle, TWO_PI)
    gap = abs(wrapped - reference)
    assert gap <= 1e-12 or abs(gap - TWO_PI) <= 1e-12


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([-3, -1, 1, 3]), st.floats(-1e-12, 1e-12))
def test_near_the_boundary_noise_moves_the_end_not_the_angle(odd, relative):
    angle = odd * math.pi * (1.0 + relative)
    wrapped = float(wrap_to_pi(angle))
    assert -math.pi < wrapped <= math.pi
    assert min(abs(wrapped - math.pi), abs(wrapped + math.pi)) <= 1e-10


@settings(max_examples=100, deadline=None)
@given(st.floats(-3.1, 3.1), st.floats(-3.1, 3.1))
def test_swing_yaw_turns_the_short_way(start_yaw, end_yaw):
    start = pin.SE3(pin.utils.rotate("z", start_yaw), np.zeros(3))
    end = pin.SE3(pin.utils.rotate("z", end_yaw), np.array([0.05, 0.0, 0.0]))
    middle = sole_path(start, end)(0.5)
    turn = math.remainder(end_yaw - start_yaw, TWO_PI)  # the short way, independently
    assume(abs(abs(turn) - math.pi) > 1e-9)  # half a turn has no short way: either is right
    expected = pin.utils.rotate("z", start_yaw + 0.5 * turn)
    assert np.allclose(middle.rotation, expected, atol=1e-9)
