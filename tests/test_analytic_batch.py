"""The closed forms' fast paths agree with the general ones they stand in for.

- every closed form's vectorised FK equals Pinocchio's FK: the batched check of ``solve_many`` measures
  errors with it;
- ``evaluate_batch`` decides exactly as the shared per-call check ``wbik.solvers.base.evaluate``;
- ``batch_targets`` accepts what ``as_target`` accepts and raises what it raises;
- the vectorised choice (screen the nearest branch first) returns the branch of screening every branch
  and taking the nearest, written out here as the reference;
- ``solve_all`` through a compiled kernel lists the vectorised path's branches.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.solvers.analytic.batch import batch_targets, evaluate_batch
from wbik.solvers.analytic.solver import AnalyticSolver
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate
from wbik.targets import Target, as_target

ROBOTS = ("arm3r", "bioloid", "golem3", "pincher", "ur5")
FORMS = [(robot, chain, kind) for robot in ROBOTS for chain, kind in sorted(wbik.load(robot).closed_forms)]
FK_AGREEMENT = 1e-10
"""Closed-form FK against Pinocchio's (m, and rotation entries): the UR5's differ by up to 4e-12 (the
URDF's offsets are rounded differently from ur_kinematics' DH numbers), the others by ~1e-16. The
batched check's errors differ from the per-call check's by at most this much."""


@pytest.fixture(scope="module")
def solvers():
    robots = {name: wbik.load(name) for name in ROBOTS}
    return {(robot, chain): wbik.solver("analytic", robots[robot], chain=chain)
            for robot, chain, _ in FORMS}


@pytest.mark.parametrize(("robot", "chain_name", "kind"), FORMS)
def test_closed_form_fk_equals_pinocchio(solvers, robot, chain_name, kind):
    """Position (and, for pose forms, rotation) of the closed-form FK against Pinocchio's, 500 joints."""
    solver = solvers[(robot, chain_name)]
    chain, form = solver.chain, solver.closed_form(kind)
    joints = chain.random(np.random.default_rng(7), 500)
    if kind == "position" and robot == "golem3":
        joints[:, 5] = form.inner.yaw  # the position form fixes the wrist roll (the same in the arm's joints)
    positions, rotations = form.fk(joints)
    for q, position, rotation in zip(joints, positions, rotations, strict=True):
        pose = chain.fk(q)
        np.testing.assert_allclose(position, pose.translation, rtol=0, atol=FK_AGREEMENT)
        if kind == "pose":
            np.testing.assert_allclose(rotation, pose.rotation, rtol=0, atol=FK_AGREEMENT)


def _per_call(chain, targets, q, found, reasons, tolerances):
    return [evaluate(chain, target, Candidate(q[i] if found[i] else None, 1, reasons[i]), tolerances, 0.5,
                     "analytic") for i, target in enumerate(targets)]


CHECKED = [("ur5", "arm", "pose"), ("golem3", "left_arm", "pose"), ("arm3r", "arm", "position"),
           ("bioloid", "right_leg", "position")]


@pytest.mark.parametrize(("robot", "chain_name", "kind"), CHECKED)
@pytest.mark.parametrize("tolerance", [1e-6, 1e-3])
def test_evaluate_batch_decides_as_evaluate(solvers, robot, chain_name, kind, tolerance):
    """Targets reached exactly, missed by 1e-7..1e-2 (either side of the tolerance), joints outside the
    limits (clipped) and targets without joints: same success, reason, joints and errors."""
    solver = solvers[(robot, chain_name)]
    chain, form = solver.chain, solver.closed_form(kind)
    rng = np.random.default_rng(3)
    count = 400
    joints = chain.random(rng, count)
    if kind == "position" and robot == "golem3":
        joints[:, 5] = form.inner.yaw
    poses = [chain.fk(q) for q in joints]
    miss = np.exp(rng.uniform(np.log(1e-7), np.log(1e-2), count)) * (rng.random(count) < 0.6)
    q = joints + miss[:, None] * rng.normal(size=joints.shape)
    outside = rng.random(count) < 0.1
    q[outside, 0] = chain.upper[0] + rng.uniform(1e-10, 1e-2, outside.sum())
    found = rng.random(count) < 0.9
    reasons = ["" if f else "unreachable: test" for f in found]
    targets = [as_target(p) if kind == "pose" else as_target(p.translation) for p in poses]
    positions = np.array([t.position for t in targets])
    rotations = np.array([t.rotation for t in targets]) if kind == "pose" else None
    tolerances = wbik.Tolerances(tolerance, tolerance)
    batch = evaluate_batch(chain, form, positions, rotations, np.where(found[:, None], q, 0.0), found,
                           reasons, tolerances, 0.5, "analytic", np.zeros(count, dtype=int))
    single = _per_call(chain, targets, q, found, reasons, tolerances)
    assert 0 < sum(r.success for r in single) < count
    for mine, theirs in zip(batch, single, strict=True):
        assert mine.success == theirs.success
        assert (mine.q is None) == (theirs.q is None)
        if theirs.q is None:
            assert mine.reason == theirs.reason
            continue
        np.testing.assert_array_equal(mine.q, theirs.q)
        for mine_xyz, theirs_xyz in ((mine.position_error_xyz, theirs.position_error_xyz),
                                     (mine.rotation_error_xyz, theirs.rotation_error_xyz)):
            np.testing.assert_allclose(mine_xyz, theirs_xyz, rtol=0, atol=FK_AGREEMENT)
        assert abs(mine.position_error - theirs.position_error) <= FK_AGREEMENT
        assert abs(mine.rotation_error - theirs.rotation_error) <= FK_AGREEMENT
        if "FK check failed" in theirs.reason:  # the figures in the text are 3 digits
            assert mine.reason.startswith("FK check failed")
        else:
            assert mine.reason == theirs.reason


def test_batch_targets_accepts_and_refuses_as_as_target(solvers):
    solver = solvers[("ur5", "ee")]
    chain = solver.chain
    poses = [chain.fk(q) for q in chain.random(np.random.default_rng(4), 50)]
    positions, rotations = batch_targets(poses, solver)
    np.testing.assert_array_equal(positions, [p.translation for p in poses])
    np.testing.assert_array_equal(rotations, [p.rotation for p in poses])
    mixed_forms = [poses[0], poses[1].homogeneous, Target(poses[2].translation, poses[2].rotation)]
    positions, rotations = batch_targets(mixed_forms, solver)
    np.testing.assert_array_equal(positions, [p.translation for p in poses[:3]])
    bad = [pin.SE3(poses[0].rotation * 1.01, poses[0].translation),
           pin.SE3(poses[0].rotation, np.array([np.nan, 0.0, 0.0])),
           pin.SE3(poses[0].rotation, np.array([2e6, 0.0, 0.0])),
           pin.SE3(-poses[0].rotation, poses[0].translation)]
    for target in bad:
        with pytest.raises(wbik.WbikError) as expected:
            as_target(target)
        with pytest.raises(type(expected.value)) as raised:
            batch_targets([*poses[:3], target], solver)
        assert str(raised.value) == str(expected.value)
    with pytest.raises(wbik.UnsupportedError, match="only full poses or only positions"):
        wbik.solver("analytic", wbik.load("golem3"), chain="right_arm").solve_many(
            [chain.fk(chain.nominal), [0.4, -0.3, 1.0]])
    assert batch_targets([], solver)[0].shape == (0, 3)


def _reference_choice(solver: AnalyticSolver, form, positions, rotations, q0s):
    """Screen every usable branch, take the nearest screened one (the first on a tie)."""
    q_all, real, usable = solver._wrapped_by_joint(form, positions, rotations, q0s)
    q_all, usable = q_all.transpose(2, 1, 0), usable.T
    targets_r = None if rotations is None else rotations[:, None]
    residual = solver._screen(form, q_all, positions[:, None], targets_r)[0]
    screened = usable & (residual <= form.screen_tolerance)
    distance = np.where(screened, np.linalg.norm(q_all - q0s[:, None], axis=-1), np.inf)
    best = np.argmin(distance, axis=1)
    return q_all[np.arange(len(best)), best], screened.any(axis=1)


@pytest.mark.parametrize(("robot", "chain_name", "kind"), FORMS)
def test_nearest_first_screening_equals_screening_every_branch(solvers, robot, chain_name, kind):
    solver = solvers[(robot, chain_name)]
    chain, form = solver.chain, solver.closed_form(kind)
    rng = np.random.default_rng(11)
    count = 60 if (robot, kind) == ("golem3", "position") else 300
    joints = chain.random(rng, count)
    poses = [chain.fk(q) for q in joints]
    poses += [pin.SE3(p.rotation, p.translation * 1.3) for p in poses[:count // 5]]  # some unreachable
    positions = np.array([p.translation for p in poses])
    rotations = np.array([p.rotation for p in poses]) if kind == "pose" else None
    q0s = chain.random(rng, len(poses))
    choice = solver._choose(form, positions, rotations, q0s)
    expected, expected_found = _reference_choice(solver, form, positions, rotations, q0s)
    found = choice.found
    np.testing.assert_array_equal(found, expected_found)
    np.testing.assert_array_equal(choice.q[found], expected[found])
    # the FK kept for the batched check is the chosen joints' FK
    reached_p, reached_r = form.fk(choice.q[found])
    np.testing.assert_allclose(choice.reached_p[found], reached_p, rtol=0, atol=1e-15)
    np.testing.assert_allclose(choice.reached_r[found], reached_r, rtol=0, atol=1e-15)



@pytest.mark.usefixtures("compiled_twins")
@pytest.mark.parametrize(("robot", "chain_name"), [("ur5", "ee"), ("ur5", "arm"), ("golem3", "right_arm"),
                                                   ("golem3", "left_arm")])
def test_compiled_solve_all_equals_the_vectorised_one(robot, chain_name):
    """solve_all through the compiled kernel (where built) against the vectorised path of the same closed
    form, including gimbal-locked and singular poses: the same branches, in the same order."""
    solver = wbik.solver("analytic", wbik.load(robot), chain=chain_name)
    chain, form = solver.chain, solver.closed_form("pose")
    joints = chain.random(np.random.default_rng(21), 150)
    joints[:10, 4] = 0.0  # UR5 wrist singularity (q5 = 0)
    if robot == "golem3":
        joints[10:20, 4] = np.pi / 2 - joints[10:20, 3]  # gimbal lock: beta = -pi/2
    poses = [chain.fk(q) for q in joints]
    compiled = [solver.solve_all(pose) for pose in poses]
    kernel, form.kernel = form.kernel, None
    try:
        vectorised = [solver.solve_all(pose) for pose in poses]
    finally:
        form.kernel = kernel
    assert sum(len(results) > 0 for results in compiled) >= 140
    for mine, theirs in zip(compiled, vectorised, strict=True):
        assert len(mine) == len(theirs)
        for a, b in zip(mine, theirs, strict=True):
            np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)


def test_a_closed_form_whose_fk_is_not_the_models_is_refused(monkeypatch):
    """solve_many (and solve_all through a kernel) check with the closed form's FK, so a form whose FK is
    not the model's must not be used: 1 um on the UR5's d4 is refused when the form is built."""
    from dataclasses import replace

    import wbik.solvers.analytic.solver as analytic
    from wbik.errors import RobotDescriptionError
    from wbik.robot_packages.ur5.closed_form import UR5, UR5EndEffector
    from wbik.solvers.analytic import model_agreement

    class Shifted(UR5EndEffector):
        geometry = replace(UR5, d4=UR5.d4 + 1e-6)

    chain = wbik.load("ur5").chain("ee")
    model_agreement.check_fk_against_model(UR5EndEffector(chain))  # the shipped one agrees
    with pytest.raises(RobotDescriptionError, match=r"differs from the robot model.s by 9\.89e-07"):
        model_agreement.check_fk_against_model(Shifted(chain))
    monkeypatch.setattr(analytic, "_closed_form", lambda chain, kind, **options: Shifted(chain))
    solver = wbik.solver("analytic", wbik.load("ur5"), "ee")
    with pytest.raises(RobotDescriptionError, match="Shifted of ur5.ee is not this chain"):
        solver.solve_many([chain.fk(chain.nominal)])
