"""Step adaptation (wbik.motion.walking.step_adaptation): the re-planned pattern, the move wanted from a DCM
error, and a pushed walk in physics that moves its steps.

Expected values are independent of the code under test: a re-plan that moves nothing must give the pattern
the preview planned (bit for bit), a move must shift every later footstep by itself, and the move wanted is
the linear pendulum's e exp(omega T) times the gain, written out here."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.errors import InvalidSettingError
from wbik.motion.walking.footsteps import StepCommand
from wbik.motion.walking.pattern import feet_at_ticks, walk_pattern
from wbik.motion.walking.preview import PreviewState
from wbik.motion.walking.step_adaptation import StepAdaptation, adapted, step_responses
from wbik.motion.walking.swing import quintic, swing_pose
from wbik.motion.walking.timeline import Timing, phase_at
from wbik.motion.walking.zmp_reference import ZmpReference


@pytest.fixture(scope="module")
def pattern():
    robot = wbik.load("bioloid")
    return walk_pattern(robot, robot.nominal, StepCommand(3, 0.03), Timing(0.25, 0.1, 0.3, 0.3))


@pytest.fixture(scope="module")
def responses(pattern):
    return step_responses(pattern)


def replanned(pattern, k: int, moved) -> tuple[np.ndarray, np.ndarray, dict]:
    """The re-plan written out: the preview run again from its planned state and error integral at k over
    the reference of ``moved``'s footsteps (the feedforward's shift kept), and every foot from tick k by the
    timeline (the swing foot blended onto its moved footstep up to touch-down)."""
    plan, dt, count = pattern.info["replan"], pattern.dt, pattern.ticks
    controller = plan.controller
    reference = ZmpReference(moved.phases, plan.centre, pattern.com[0, :2])
    targets = reference(dt * np.arange(count + controller.steps + 1))
    tracked = targets + plan.zmp_shift[:len(targets)]
    state = PreviewState(controller, plan.states[k].copy())
    state.error_sum = plan.error_sums[k].copy()
    com, zmp = pattern.com.copy(), pattern.lipm_zmp.copy()
    for tick in range(k, count):
        com[tick, :2], zmp[tick] = state.x[0], controller.zmp_of(state.x[0], state.x[2])
        state.step(tracked[tick + 1:tick + 1 + controller.steps], tracked[tick])
    phase = phase_at(pattern.phases, k * dt)
    touch = int(round(phase_at(moved.phases, k * dt).end / dt))
    feet = feet_at_ticks(moved.phases, pattern.feet, dt, count, pattern.clearance)[0]
    move = moved.footsteps[-1].placement.translation - pattern.footsteps[-1].placement.translation
    lift, target = phase.feet[phase.swing.side], phase.swing.placement
    at_k = phase.fraction(k * dt)
    for tick in range(k, touch):  # the old swing, re-timed to touch down at ``touch``, blended onto the move
        share = (tick - k) / (touch - k)
        pose = swing_pose(lift, target, at_k + (1 - at_k) * share, pattern.clearance)
        feet[phase.swing.side][tick] = pin.SE3(pose.rotation, pose.translation + quintic(share) * move)
    return com, zmp, feet


def single_support_tick(pattern, which: int = 1) -> int:
    """A tick early in the ``which``-th single support."""
    starts = [k for k in range(1, pattern.ticks)
              if pattern.swing[k] is not None and pattern.swing[k - 1] is None]
    return starts[which] + 2


def test_a_replan_that_moves_nothing_is_the_planned_pattern(pattern, responses):
    k = single_support_tick(pattern)
    same = adapted(pattern, k, np.zeros(2), responses)
    assert np.array_equal(same.com, pattern.com) and np.array_equal(same.lipm_zmp, pattern.lipm_zmp)
    assert np.array_equal(same.zmp_reference, pattern.zmp_reference)
    for side, poses in pattern.feet_poses.items():
        assert all(np.allclose(a.homogeneous, b.homogeneous, rtol=0, atol=1e-15)
                   for a, b in zip(same.feet_poses[side], poses, strict=True))


@pytest.mark.parametrize("which", [0, 1, 3])  # the last (4th) moves the final reference by half
@pytest.mark.parametrize("sooner", [0, 4])  # touch-down 4 ticks earlier, the later phases with it
def test_the_replan_is_the_preview_run_again_over_the_moved_reference(pattern, responses, which, sooner):
    k = single_support_tick(pattern, which)
    moved = adapted(pattern, k, np.array([0.012, -0.005]), responses, sooner)
    com, zmp, feet = replanned(pattern, k, moved)
    assert np.max(np.abs(moved.com - com)) < 1e-12 and np.max(np.abs(moved.lipm_zmp - zmp)) < 1e-12
    for side in feet:
        for tick in range(k, pattern.ticks):
            assert np.allclose(moved.feet_poses[side][tick].homogeneous, feet[side][tick].homogeneous,
                               rtol=0, atol=1e-14), (side, tick)


def test_a_move_shifts_the_later_steps_and_lands_the_swing_foot_there(pattern, responses):
    k = single_support_tick(pattern)
    move = np.array([0.01, 0.004])
    moved = adapted(pattern, k, move, responses)
    side = pattern.swing[k]
    lifted = pattern.feet_poses[side][k - 3].translation[0]
    taken = next(i for i, step in enumerate(pattern.footsteps)
                 if step.side == side and step.placement.translation[0] > lifted + 1e-3)
    for before, after in zip(pattern.footsteps[taken:], moved.footsteps[taken:], strict=True):
        shift = after.placement.translation - before.placement.translation
        assert np.allclose(shift, [*move, 0.0], atol=1e-15)
    for before, after in zip(pattern.footsteps[:taken], moved.footsteps[:taken], strict=True):
        assert np.array_equal(after.placement.translation, before.placement.translation)
    landing = next(t for t in range(k, pattern.ticks) if pattern.swing[t] is None)
    shift = moved.feet_poses[side][landing].translation - pattern.feet_poses[side][landing].translation
    assert np.allclose(shift, [*move, 0.0], atol=1e-12)
    assert np.array_equal(moved.com[:k + 1], pattern.com[:k + 1])  # the plan before and at the tick kept
    assert np.linalg.norm(moved.com[-1, :2] - pattern.com[-1, :2] - move) < 2e-3  # ends over the moved feet


def test_the_move_is_the_predicted_error_times_the_gain_capped_and_never_across(pattern):
    k = single_support_tick(pattern)
    omega, remaining = pattern.info["omega"], 0.1
    settings = StepAdaptation(gain=0.5, threshold_m=0.005, offset_max_m=0.03)  # on e exp(omega T)
    error = np.array([0.004, 0.0])
    expected = 0.5 * 0.004 * math.exp(omega * remaining)
    assert np.allclose(settings.offset(pattern, k, error, remaining), [expected, 0.0], rtol=1e-12)
    assert not np.any(settings.offset(pattern, k, np.array([0.001, 0.0]), remaining))  # under the threshold
    capped = settings.offset(pattern, k, np.array([0.05, 0.0]), remaining)
    assert np.linalg.norm(capped) == pytest.approx(0.03, rel=1e-12)
    stance = "left" if pattern.swing[k] == "right" else "right"
    feet = pattern.feet_poses
    inward = feet[stance][k].translation[1] - feet[pattern.swing[k]][k].translation[1]
    across = settings.offset(pattern, k, np.array([0.0, 0.01 * np.sign(inward)]), remaining)
    assert abs(across[1]) < 1e-15  # the swing foot is not moved toward the stance foot


@pytest.mark.parametrize("field", ["gain", "threshold_m", "offset_max_m", "min_remaining_s", "change_m"])
def test_bad_settings_raise_a_typed_error(field):
    with pytest.raises(InvalidSettingError, match=field):
        StepAdaptation(**{field: -1.0})


def test_a_pushed_walk_moves_its_steps_in_physics():
    pytest.importorskip("mujoco")
    from wbik.scenarios import run_scenario

    arms = [f"{s}_{n}" for s in "rl" for n in ("shoulder_pitch", "shoulder_roll", "elbow")]
    spec = {"kind": "walk", "name": "adapted", "robot": "bioloid", "trunk": "pelvis", "locked": arms,
            "timing": {"single_support_s": 0.25, "double_support_s": 0.1, "start_s": 0.3, "end_s": 0.3},
            "clearance": 0.015, "margin": 0.004, "preview": {"horizon_s": 1.0, "q": 1.0, "r": 1.0e-5},
            "physics": {"servos": {"kp": 37.05, "damping": 0.243, "torque_limit": 1.5, "armature": 1e-3},
                        "settle_s": 0.2,
                        "step_adaptation": {"gain": 0.5, "threshold_m": 0.005, "offset_max_m": 0.012,
                                            "min_remaining_s": 0.03, "sooner_max_s": 0.05},
                        "push": {"impulse_n_s": 0.3, "step": 1, "duration_s": 0.05,
                                 "directions": ["forward"]}},
            "walks": [{"steps": 2, "length": 0.02}]}
    physics = run_scenario(spec, source="adapted")["walks"][0]["physics"]
    assert physics["step_adaptation"]["gain"] == 0.5
    pushed = physics["pushed"]["forward"]
    assert 0 < pushed["step_move_max_m"] <= 0.012 + 1e-12
    assert 0 < pushed["touch_down_sooner_max_s"] <= 0.05 + 1e-12  # the move wanted was over the cap


@settings(max_examples=60, deadline=None)
@given(error=st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)), remaining=st.floats(0.0, 0.25),
       gain=st.floats(0.0, 2.0), cap=st.floats(0.0, 0.05))
def test_any_move_stays_under_its_cap_and_never_crosses_toward_the_stance_foot(pattern, error, remaining,
                                                                              gain, cap):
    k = single_support_tick(pattern)
    move = StepAdaptation(gain=gain, threshold_m=0.005, offset_max_m=cap).offset(
        pattern, k, np.array(error), remaining)
    assert np.linalg.norm(move) <= cap * (1 + 1e-12) + 1e-15
    stance = "left" if pattern.swing[k] == "right" else "right"
    feet = pattern.feet_poses
    inward = np.sign(feet[stance][k].translation[1] - feet[pattern.swing[k]][k].translation[1])
    assert inward * move[1] <= 1e-15  # the feet here point along x: across is the y axis
    predicted = np.linalg.norm(error) * math.exp(pattern.info["omega"] * remaining)
    if predicted <= 0.005 * (1 - 1e-9):
        assert not np.any(move)


@settings(max_examples=80, deadline=None)
@given(size=st.floats(0.0, 0.05), remaining=st.floats(0.0, 0.3), gain=st.floats(0.05, 2.0),
       cap=st.floats(0.001, 0.05), most=st.floats(0.0, 0.2))
def test_a_touch_down_comes_sooner_only_as_much_as_keeps_the_move_at_its_cap(size, remaining, gain, cap,
                                                                             most):
    omega, least = 7.0, 0.03
    settings = StepAdaptation(gain=gain, offset_max_m=cap, min_remaining_s=least, sooner_max_s=most)
    sooner = settings.sooner(omega, np.array([size, 0.0]), remaining)
    wanted = gain * size * math.exp(omega * remaining)
    assert 0.0 <= sooner <= most + 1e-12 and sooner <= max(remaining - least, 0.0) + 1e-12
    if wanted <= cap or most == 0:
        assert sooner == 0.0
    elif 0 < sooner < min(most, remaining - least) - 1e-9:  # not bounded: the move at the cap exactly
        assert gain * size * math.exp(omega * (remaining - sooner)) == pytest.approx(cap, rel=1e-9)
