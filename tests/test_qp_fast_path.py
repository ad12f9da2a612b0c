"""The QP hot path's shortcuts agree with the general computation they replace: bounds tightened and
q clipped through slice views, H and c refilled in per-level buffers, the contact violation summed in
Python floats, the kinematics' "stands at q" test, and a profiled IK solve against an unprofiled one."""

import math

import numpy as np
import pinocchio as pin
import pytest
from qp_models import build_biped

from wbik.qp import FrameTask, IKProblem, OrientationTask, RegularizationTask, backends
from wbik.qp.contacts import Contact
from wbik.qp.humanoid import stance_constraints
from wbik.qp.kinematics import Kinematics
from wbik.qp.limits import JointPositionLimits
from wbik.qp.problem import PHASES, SOLVE_PHASES
from wbik.qp.step import Level


@pytest.fixture(scope="module")
def biped():
    return build_biped()


def test_tightening_through_a_slice_equals_tightening_by_indices():
    rng = np.random.default_rng(0)
    for _ in range(50):
        by_slice, by_index = backends.StackedConstraints(8), backends.StackedConstraints(8)
        radius = rng.uniform(0.01, 1.0)
        for stack in (by_slice, by_index):
            stack.clear(radius)
        start, stop = sorted(rng.choice(9, size=2, replace=False))
        lower, upper = rng.uniform(-2, 0.5, stop - start), rng.uniform(-0.5, 2, stop - start)
        by_slice.tighten(slice(start, stop), lower, upper)
        by_index.tighten(np.arange(start, stop), lower, upper)
        by_slice.tighten(slice(start, stop), -0.3, 0.3)  # scalars too
        by_index.tighten(np.arange(start, stop), -0.3, 0.3)
        for stack in (by_slice, by_index):
            stack.close_box()
        np.testing.assert_array_equal(by_slice.lower, by_index.lower)
        np.testing.assert_array_equal(by_slice.upper, by_index.upper)


def test_clipping_through_a_slice_equals_clipping_by_indices(biped):
    limits = JointPositionLimits()
    limits.bind(biped.model)
    assert isinstance(limits._q_rows, slice)  # the biped's bounded joints are consecutive in q
    rng = np.random.default_rng(1)
    for _ in range(50):
        q = biped.nominal + rng.normal(scale=2.0, size=biped.model.nq)
        by_slice = q.copy()
        limits.clip(by_slice)
        by_index = q.copy()
        by_index[limits.q_index] = np.minimum(np.maximum(q[limits.q_index], limits.lower), limits.upper)
        np.testing.assert_array_equal(by_slice, by_index)


def test_level_quadratic_equals_the_plain_formula_and_does_not_accumulate(biped):
    kinematics = Kinematics(biped.model, biped.nominal)
    target = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.05, 0.1, 0.02]))
    tasks = [FrameTask("l_sole", target, orientation_weight=0.5, gain=0.8),
             OrientationTask("pelvis", np.eye(3), weight=0.1, goal=False), RegularizationTask(1e-4)]
    for task in tasks:
        task.start(kinematics)
    level = Level(tasks, kinematics.nv)
    rng = np.random.default_rng(2)
    for _ in range(5):
        dq = rng.normal(scale=0.2, size=biped.model.nv)
        kinematics.update(pin.integrate(biped.model, biped.nominal, dq))
        level.fill(kinematics)
        damping = rng.uniform(1e-9, 1e-3)
        for _ in range(2):  # the buffers are refilled, not added to
            H, c = level.quadratic(damping)
            J = np.vstack([tasks[0].jacobian(kinematics).copy(), tasks[1].jacobian(kinematics)])
            e = np.concatenate([tasks[0].error(kinematics).copy(), tasks[1].error(kinematics)])
            w = np.concatenate([tasks[0].weight, tasks[1].weight])
            gain = np.r_[np.full(6, 0.8), np.ones(3)]
            plain_H = J.T @ (w[:, None] * J) + np.diag(np.full(kinematics.nv, 1e-4) + damping)
            plain_c = J.T @ (w * gain * e)
            np.testing.assert_allclose(H, plain_H, rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(c, plain_c, rtol=1e-12, atol=1e-14)


def test_contact_violation_equals_the_larger_norm_of_its_error(biped):
    kinematics = Kinematics(biped.model, biped.nominal)
    contact = Contact("r_sole")
    contact.start(kinematics)
    rng = np.random.default_rng(3)
    for scale in (1e-9, 1e-4, 0.1):
        dq = rng.normal(scale=scale, size=biped.model.nv)
        kinematics.update(pin.integrate(biped.model, biped.nominal, dq))
        error = contact.error(kinematics).copy()
        squared = error * error
        expected = math.sqrt(max(float(squared[:3].sum()), float(squared[3:].sum())))
        assert contact.violation(kinematics) == expected
        norms = np.linalg.norm(error[:3]), np.linalg.norm(error[3:])
        assert math.isclose(expected, max(norms), rel_tol=1e-14)


def _problem(biped, q):
    target = biped.frame_placement(q, "l_sole")
    target.translation = target.translation + np.array([0.01, 0.0, 0.02])
    tasks = [FrameTask("l_sole", target, tolerance=1e-6),
             OrientationTask("pelvis", biped.frame_placement(q, "pelvis").rotation, weight=0.1, goal=False),
             RegularizationTask(1e-6)]
    return IKProblem(biped.model, tasks, stance_constraints(biped, q, ["r_sole"], margin=0.005))


def test_stands_at_agrees_with_array_equal(biped):
    problem = _problem(biped, biped.nominal)
    problem.start(biped.nominal)
    q = problem.kinematics.q.copy()
    assert problem._stands_at(q) and np.array_equal(q, problem.kinematics.q)
    q[3] += 1e-15
    assert not problem._stands_at(q) and not np.array_equal(q, problem.kinematics.q)
    q[:] = np.nan
    assert not problem._stands_at(q)


def test_a_profiled_solve_takes_the_same_iterates_and_times_every_phase(biped):
    q = biped.nominal
    plain = _problem(biped, q).solve(q)
    profile: dict[str, float] = {}
    profiled = _problem(biped, q).solve(q, profile=profile)
    assert plain.success and profiled.success
    np.testing.assert_array_equal(plain.q, profiled.q)
    assert plain.iterations == profiled.iterations and plain.task_errors == profiled.task_errors
    assert set(profile) == set(PHASES) | set(SOLVE_PHASES)
    assert all(seconds >= 0.0 for seconds in profile.values())
