"""The QP layer on fixed-base arms and a small floating-base biped (independent of the Bioloid)."""

import numpy as np
import pinocchio as pin
import pytest
from qp_models import build_biped

import wbik
from wbik.qp import (
    ComTask,
    FrameTask,
    IKProblem,
    JointPositionLimits,
    JointVelocityLimits,
    MinimumDistance,
    OrientationTask,
    PositionTask,
    PostureTask,
    RegularizationTask,
    available_backends,
)
from wbik.qp.humanoid import stance_constraints, support_polygon


@pytest.fixture(scope="module")
def biped():
    return build_biped()


@pytest.fixture(scope="module")
def panda():
    return wbik.load("panda")


@pytest.mark.parametrize("backend", available_backends())
def test_every_backend_solves_a_panda_pose(panda, backend):
    q_goal = panda.nominal.copy()
    q_goal[:7] = [0.2, -0.3, 0.1, -2.1, 0.2, 1.8, 0.4]
    target = panda.frame_placement(q_goal, "panda_hand_tcp")
    problem = IKProblem(panda.model, [FrameTask("panda_hand_tcp", target), RegularizationTask(1e-9)],
                        [JointPositionLimits()], backend=backend)
    solution = problem.solve(panda.nominal)
    assert solution.success, solution.reason
    reached = panda.frame_placement(solution.q, "panda_hand_tcp")
    assert np.linalg.norm(reached.translation - target.translation) < 1e-6
    assert np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation)) < 1e-6


def test_joint_limits_hold_when_the_target_pulls_past_them(panda):
    model = panda.model
    # a target far beyond the reach: the best effort must stay inside the limits
    problem = IKProblem(model, [PositionTask("panda_hand_tcp", [2.0, 0.0, 0.5])],
                        [JointPositionLimits()], backend="daqp")
    solution = problem.solve(panda.nominal)
    assert not solution.success
    assert np.all(solution.q >= model.lowerPositionLimit - 1e-12)
    assert np.all(solution.q <= model.upperPositionLimit + 1e-12)
    assert solution.task_errors["PositionTask[panda_hand_tcp]"] > 0.5  # reach is ~0.9 m


def test_velocity_limits_bound_one_control_step(panda):
    model = panda.model
    target = pin.SE3(np.eye(3), np.array([0.3, 0.3, 0.3]))
    problem = IKProblem(model, [FrameTask("panda_hand_tcp", target)],
                        [JointPositionLimits(), JointVelocityLimits()], backend="daqp")
    dt = 0.01
    dq = problem.step(panda.nominal, dt=dt)
    assert np.all(np.abs(dq) <= model.velocityLimit * dt + 1e-9)
    assert np.max(np.abs(dq) / (model.velocityLimit * dt)) > 0.99  # a far target saturates a joint


def test_priority_level_is_not_biased_by_a_lower_level(panda):
    model = panda.model
    q_goal = panda.nominal.copy()
    q_goal[:7] = [0.5, -0.2, 0.3, -1.8, -0.2, 2.0, 0.9]
    target = panda.frame_placement(q_goal, "panda_hand_tcp").translation
    far_posture = panda.nominal.copy()
    far_posture[:7] = [-1.0, 0.5, -1.0, -1.0, 1.0, 1.0, -1.0]
    same_level = IKProblem(model, [PositionTask("panda_hand_tcp", target),
                                   PostureTask(far_posture, weight=1.0)],
                           [JointPositionLimits()], backend="daqp")
    ranked = IKProblem(model, [PositionTask("panda_hand_tcp", target),
                               PostureTask(far_posture, weight=1.0, priority=1)],
                       [JointPositionLimits()], backend="daqp")
    biased = same_level.solve(panda.nominal)
    exact = ranked.solve(panda.nominal)
    assert biased.task_errors["PositionTask[panda_hand_tcp]"] > 1e-3   # the posture pulls it away
    assert exact.task_errors["PositionTask[panda_hand_tcp]"] < 1e-6
    # and the posture is still served in the null space: closer to it than from the start
    start_gap = np.linalg.norm(pin.difference(model, far_posture, panda.nominal))
    assert np.linalg.norm(pin.difference(model, far_posture, exact.q)) < start_gap


def test_minimum_distance_holds(panda):
    model = panda.model
    target = panda.frame_placement(panda.nominal, "panda_link0").translation + np.array([0.0, 0.0, 0.1])
    problem = IKProblem(model, [PositionTask("panda_hand_tcp", target)],
                        [JointPositionLimits(), MinimumDistance("panda_hand_tcp", "panda_link0", 0.3)],
                        backend="daqp")
    solution = problem.solve(panda.nominal)
    reached = panda.frame_placement(solution.q, "panda_hand_tcp").translation
    base = panda.frame_placement(solution.q, "panda_link0").translation
    assert np.linalg.norm(reached - base) >= 0.3 - 1e-9
    assert not solution.success


def _contact_error(robot, q, frame, placement):
    reached = robot.frame_placement(q, frame)
    return max(np.linalg.norm(reached.translation - placement.translation),
               np.linalg.norm(pin.log3(placement.rotation.T @ reached.rotation)))


def test_biped_shift_lift_and_balanced_best_effort(biped):
    q0 = biped.nominal
    soles = {f: biped.frame_placement(q0, f) for f in ("r_sole", "l_sole")}
    pelvis = OrientationTask("pelvis", np.eye(3), weight=0.1, goal=False)
    right = soles["r_sole"].translation
    shift = IKProblem(biped.model, [ComTask([right[0], right[1], 0.0], axes="xy"), pelvis,
                                    RegularizationTask(1e-6)],
                      stance_constraints(biped, q0, ["r_sole", "l_sole"], margin=0.005), backend="daqp")
    first = shift.solve(q0)
    assert first.success, first.reason
    for frame, placement in soles.items():  # a converged answer holds its contacts to 1e-10
        assert _contact_error(biped, first.q, frame, placement) < 1e-10
    assert np.linalg.norm(biped.center_of_mass(first.q)[:2] - right[:2]) < 1e-6

    lifted = soles["l_sole"].copy()
    lifted.translation = lifted.translation + np.array([0.0, 0.0, 0.04])
    lift = IKProblem(biped.model, [FrameTask("l_sole", lifted), pelvis, RegularizationTask(1e-6)],
                     stance_constraints(biped, first.q, ["r_sole"], margin=0.005), backend="daqp")
    second = lift.solve(first.q)
    assert second.success, second.reason
    assert _contact_error(biped, second.q, "r_sole", soles["r_sole"]) < 1e-10
    assert _contact_error(biped, second.q, "l_sole", lifted) < 1e-6
    # CoM inside the right sole shrunk by 5 mm, by hand: |x - 0| <= 0.045, |y + 0.05| <= 0.025
    com = biped.center_of_mass(second.q)
    assert abs(com[0]) <= 0.045 + 1e-9 and abs(com[1] + 0.05) <= 0.025 + 1e-9

    # a hand target far ahead conflicts with balance: best effort, never a fall
    hand = biped.frame_placement(second.q, "r_hand").translation + np.array([0.3, 0.0, 0.0])
    reach = IKProblem(biped.model, [PositionTask("r_hand", hand), RegularizationTask(1e-6)],
                      stance_constraints(biped, second.q, ["r_sole"], margin=0.005), backend="daqp")
    third = reach.solve(second.q)
    assert not third.success and third.feasible
    assert third.task_errors["PositionTask[r_hand]"] > 0.01
    assert _contact_error(biped, third.q, "r_sole", soles["r_sole"]) < 1e-10  # projected, best effort too
    com = biped.center_of_mass(third.q)
    assert abs(com[0]) <= 0.045 + 1e-9 and abs(com[1] + 0.05) <= 0.025 + 1e-9
    assert support_polygon(biped, third.q, ["r_sole"]).margin_of(com) >= 0.005 - 1e-9


def test_a_step_without_solution_raises_and_the_loop_reports_the_solvers_status(panda):
    """Every joint locked and a contact held 5 cm from where the hand is: J dq = -e cannot hold
    with dq = 0, so the step raises NoQPSolutionError with DAQP's exit flag (here -6: the equalities
    and the locked bounds overdetermine the working set) and solve() returns a failed solution whose
    reason says so (instead of a silent None)."""
    from wbik.errors import NoQPSolutionError
    from wbik.qp.contacts import Contact
    from wbik.qp.limits import LockedJoints
    model = panda.model
    held = panda.frame_placement(panda.nominal, "panda_hand_tcp")
    held.translation = held.translation + np.array([0.05, 0.0, 0.0])
    joints = [name for name in model.names[1:] if model.joints[model.getJointId(name)].nv == 1]
    problem = IKProblem(model, [PositionTask("panda_hand_tcp", held.translation)],
                        [Contact("panda_hand_tcp", held), LockedJoints(joints)], backend="daqp")
    with pytest.raises(NoQPSolutionError) as caught:
        problem.step(panda.nominal)
    assert caught.value.backend == "daqp" and caught.value.status < 0
    assert f"exit flag {caught.value.status}" in str(caught.value)
    solution = problem.solve(panda.nominal)
    assert not solution.success and not solution.converged
    assert "no solution" in solution.reason and f"exit flag {caught.value.status}" in solution.reason
