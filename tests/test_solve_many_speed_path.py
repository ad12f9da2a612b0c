"""The shortcuts of ``analytic``'s batched path give the answers of the rules they stand in for.

- :func:`wrap_into_limits` takes the 2 pi shift nearest the reference without trying the others where
  that shift provably wins; bit for bit, it equals trying the five shifts in order
  (:func:`wbik.solvers.analytic._wrap_by_shifts`, the rule) on every angle, including near ties,
  angles on and just outside a limit, -0.0, NaN, inf and prismatic joints, in either layout;
- the UR family's batch-last branches (``branches_by_joint``, q4 from the elbow's direction without
  trigonometry) are every branch, and ``solve_many`` equals ``solve`` on singular, axis-aligned and
  unreachable UR5 poses;
- the choice, which screens the nearest branch of every target at once and sorts only where it
  missed, equals screening every branch;
- ``batch_targets``'s vectorised SE3 check accepts exactly what ``as_target``'s fast path accepts.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.geometry import TWO_PI
from wbik.solvers.analytic import ur_type
from wbik.solvers.analytic.closed_form import LIMIT_TOLERANCE, ClosedForm, _wrap_by_shifts, wrap_into_limits
from wbik.solvers.analytic.subproblems import planar_2r, planar_2r_elbow


def _rule(q, reference, lower, upper, revolute):
    """Every angle through the five shifts (no shortcut), set into the limits."""
    q = np.asarray(q, dtype=float)
    shape = q.shape
    fixed = None if np.all(revolute) else np.broadcast_to(~np.asarray(revolute, dtype=bool), shape).ravel()
    wrapped, inside = _wrap_by_shifts(
        q.ravel(), np.broadcast_to(reference, shape).ravel(),
        np.broadcast_to(lower - LIMIT_TOLERANCE, shape).ravel(),
        np.broadcast_to(upper + LIMIT_TOLERANCE, shape).ravel(), fixed)
    wrapped = np.clip(wrapped, np.broadcast_to(lower, shape).ravel(), np.broadcast_to(upper, shape).ravel())
    return wrapped.reshape(shape), np.all(inside.reshape(shape), axis=-1)


def _bits(values: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(values).view(np.int64)


LIMITS = {
    "ur5": (np.array([-TWO_PI, -TWO_PI, -math.pi, -TWO_PI, -TWO_PI, -TWO_PI]),
            np.array([TWO_PI, TWO_PI, math.pi, TWO_PI, TWO_PI, TWO_PI])),
    "golem3": (np.array([-1.0, -1.14, -3.0, -1.55, -1.67, -1.5]),
               np.array([1.0, 1.75, 3.0, 1.55, 1.67, 1.5])),
    "wide": (np.full(6, -3.0 * TWO_PI), np.full(6, 3.0 * TWO_PI)),
    "one-sided": (np.array([0.0, -0.5, -TWO_PI, 1.0, -4.0, -0.1]),
                  np.array([TWO_PI, 0.5, 0.0, 5.0, 4.0, 0.1])),
}


def _angles(rng: np.random.Generator, lower: np.ndarray, upper: np.ndarray, count: int) -> tuple[np.ndarray,
                                                                                             np.ndarray]:
    """(q (count, 8, 6), reference (count, 1, 6)): closed-form-like angles in (-2 pi, 2 pi) and beyond,
    with near ties, angles on and around the limits, signed zeros and non-finite values mixed in."""
    q = rng.uniform(-TWO_PI, TWO_PI, (count, 8, 6))
    q[: count // 10] *= 3.0  # some beyond +-4 pi
    reference = rng.uniform(lower, upper, (count, 1, 6))
    reference[: count // 8] = 0.0
    ties = rng.random(q.shape) < 0.05  # q - reference within rounding of +-pi
    q[ties] = (np.broadcast_to(reference, q.shape)[ties] + rng.choice([-1.0, 1.0], ties.sum()) * math.pi
               + rng.choice([-1e-9, -1e-12, 0.0, 1e-12, 1e-9], ties.sum()))
    edges = rng.random(q.shape) < 0.05  # on a limit, just inside, just outside, a turn away
    limit = np.where(rng.random(q.shape) < 0.5, lower, upper)
    q[edges] = (limit[edges] + rng.choice([-2e-9, -1e-9, -1e-10, 0.0, 1e-10, 1e-9, 2e-9], edges.sum())
                + rng.choice([-TWO_PI, 0.0, TWO_PI], edges.sum()))
    specials = rng.random(q.shape) < 0.01
    q[specials] = rng.choice([0.0, -0.0, np.nan, np.inf, -np.inf, TWO_PI, -TWO_PI, math.pi], specials.sum())
    return q, reference


@pytest.mark.parametrize("limits", sorted(LIMITS))
@pytest.mark.parametrize("prismatic", [False, True])
def test_wrap_into_limits_equals_trying_every_shift(limits, prismatic):
    lower, upper = LIMITS[limits]
    revolute = np.ones(6, dtype=bool)
    if prismatic:
        revolute[[2, 5]] = False
    rng = np.random.default_rng(16)
    q, reference = _angles(rng, lower, upper, 3000)
    wrapped, inside = wrap_into_limits(q, reference, lower, upper, revolute)
    expected, expected_inside = _rule(q, reference, lower, upper, revolute)
    np.testing.assert_array_equal(inside, expected_inside)
    np.testing.assert_array_equal(_bits(wrapped), _bits(expected))  # -0.0 and NaN included
    assert 0 < inside.sum() < len(inside.ravel())


def test_wrap_into_limits_of_one_vector_and_of_signed_zeros():
    """A single joint vector against a single reference, and -0.0 (q5 at the wrist singularity) comes back
    as the rule's q + 0.0 = +0.0."""
    lower, upper = LIMITS["ur5"]
    q = np.array([-0.0, 0.0, -0.0, 3.0 * math.pi, -7.0, math.pi])
    for reference in (np.zeros(6), np.full(6, -0.5), np.full(6, 0.5)):
        wrapped, inside = wrap_into_limits(q, reference, lower, upper, np.ones(6, dtype=bool))
        expected, expected_inside = _rule(q, reference, lower, upper, np.ones(6, dtype=bool))
        assert inside == expected_inside
        np.testing.assert_array_equal(_bits(wrapped), _bits(expected))
        assert not np.signbit(wrapped[:3]).any()


def test_wrap_into_limits_joint_major_equals_target_by_target():
    """The joint axis first (q (n, K, B), limits (n, 1, 1)), as solve_many's choice lays it out: the same
    angles and in-limits masks as the target-by-target layout."""
    lower, upper = LIMITS["one-sided"]
    revolute = np.array([True, True, False, True, True, True])
    q, reference = _angles(np.random.default_rng(17), lower, upper, 2000)
    wrapped, inside = wrap_into_limits(q, reference, lower, upper, revolute)
    by_joint, inside_by_joint = wrap_into_limits(
        np.ascontiguousarray(q.transpose(2, 1, 0)), np.ascontiguousarray(reference.transpose(2, 1, 0)),
        lower[:, None, None], upper[:, None, None], revolute[:, None, None], axis=0)
    # values (NaN where NaN); not bits: np.clip's choice between -0.0 and a bound of 0.0 depends on its loop
    np.testing.assert_array_equal(by_joint.transpose(2, 1, 0), wrapped)
    np.testing.assert_array_equal(inside_by_joint.T, inside)


@pytest.fixture(scope="module")
def ur5():
    robot = wbik.load("ur5")
    return {name: wbik.solver("analytic", robot, chain=name) for name in ("ee", "arm")}


def _ur5_poses(chain, count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joints, positions, rotations) of FK poses, with wrist-singular (q5 = 0, pi), stretched-elbow and
    axis-aligned joints among them, and some poses out of reach."""
    joints = chain.random(np.random.default_rng(seed), count)
    joints[:20, 4] = 0.0
    joints[20:40, 4] = math.pi
    joints[40:60, 2] = 0.0
    joints[60:80] = np.round(joints[60:80] / (math.pi / 2)) * (math.pi / 2)
    poses = [chain.fk(q) for q in joints]
    positions = np.array([p.translation for p in poses])
    positions[80:100] *= 1.3
    return joints, positions, np.array([p.rotation for p in poses])


def _agreement(joints: np.ndarray) -> float:
    """How closely solve_many and solve (one path, or the kernel and its twin: compiled_twins) agree on the
    pose of ``joints``: at a stretched elbow (sin q3 ~ 0) the elbow angle, sqrt(1 - c^2) of its cosine
    c ~ 1, turns a last bit of c into ~1e-10 rad (both pass the FK check); elsewhere, to rounding."""
    return 1e-7 if abs(math.sin(joints[2])) < 1e-6 else 1e-12


def test_ur_branches_by_joint_are_every_branch(ur5):
    """The batch-last UR family (solve_many's): every real branch reaches its pose by the form's FK, the
    original joints are a branch of every reachable pose off the wrist singularity, and ``branches`` is the
    same set target by target."""
    form = ur5["ee"].closed_form("pose")
    joints, positions, rotations = _ur5_poses(ur5["ee"].chain, 400, 18)
    starts = ur5["ee"].chain.random(np.random.default_rng(19), len(joints))
    q_all, real = form.branches_by_joint(positions, rotations, starts)
    assert q_all.shape == (6, 8, len(joints)) and real.shape == (8, len(joints))
    reached_p, reached_r = form.fk(q_all.transpose(2, 1, 0))
    for index in np.flatnonzero(real.any(axis=0)):
        branches = real[:, index]
        np.testing.assert_allclose(reached_p[index, branches] - positions[index], 0.0, rtol=0, atol=1e-9)
        np.testing.assert_allclose(reached_r[index, branches] - rotations[index], 0.0, rtol=0, atol=1e-9)
        gaps = np.abs(np.angle(np.exp(1j * (q_all[:, branches, index].T - joints[index]))))
        stretched = abs(math.sin(joints[index, 2])) < 1e-6  # q3 = acos(c ~ 1): ~sqrt(rounding) off
        singular_wrist = abs(math.sin(joints[index, 4])) < 1e-6  # q6 is then the start's
        if not singular_wrist and index not in range(80, 100):  # (80..99: scaled out of reach)
            assert (gaps.max(axis=1) < (1e-5 if stretched else 1e-7)).any()
    by_target, real_by_target = form.branches(positions, rotations, starts)
    np.testing.assert_array_equal(by_target, q_all.transpose(2, 1, 0))
    np.testing.assert_array_equal(real_by_target, real.T)
    assert 0 < real.any(axis=0).sum() < len(joints)


def test_ur_dh_conversion_is_base_r_ee_transpose():
    """The family reads T_dh = B R E^T off the rotation's entries: the documented B = Rz(pi) and
    E = link6 -> ee_link give the same entries."""
    angles = np.random.default_rng(20).normal(size=(50, 3))
    rotations = np.array([pin.rpy.rpyToMatrix(*rpy) for rpy in angles])
    dh = np.einsum("ij,bjk,lk->bil", ur_type.BASE_TO_LINK0, rotations, ur_type.LINK6_TO_EE)
    entries = rotations.reshape(-1, 9)
    signs = np.array([1.0, 1.0, -1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0])
    by_hand = (signs * entries[:, [1, 2, 0, 4, 5, 3, 7, 8, 6]]).reshape(-1, 3, 3)
    np.testing.assert_array_equal(dh, by_hand)


def test_tool_form_branches_by_joint_are_its_branches(ur5):
    """The UR5 tool chain ``arm`` forwards both layouts through the same flange targets."""
    form = ur5["arm"].closed_form("pose")
    joints, _, _ = _ur5_poses(ur5["arm"].chain, 200, 21)
    poses = [ur5["arm"].chain.fk(q) for q in joints]
    positions, rotations = np.array([p.translation for p in poses]), np.array([p.rotation for p in poses])
    q_all, real = form.branches_by_joint(positions, rotations, joints)
    by_target, real_by_target = form.branches(positions, rotations, joints)
    np.testing.assert_array_equal(by_target, q_all.transpose(2, 1, 0))
    np.testing.assert_array_equal(real_by_target, real.T)


def test_planar_2r_elbow_axis():
    """The elbow branch on axis -2 (batch-last) holds the values of the default last axis."""
    rng = np.random.default_rng(22)
    x, y = rng.uniform(-1.0, 1.0, (2, 3, 50))
    default = planar_2r(x, y, -0.425, -0.39225)
    batch_last = planar_2r(x, y, -0.425, -0.39225, axis=-2)
    for last, moved in zip(default[:2], batch_last[:2], strict=True):
        np.testing.assert_array_equal(np.moveaxis(moved, -2, -1), last)
    np.testing.assert_array_equal(default[2], batch_last[2])
    assert 0 < default[2].sum() < default[2].size


@pytest.mark.parametrize("chain_name", ["ee", "arm"])
def test_ur5_solve_many_equals_solve_on_hard_poses(ur5, chain_name):
    """solve_many (batch-last branches, the nearest-shift wrap, argmin before any sort) against solve
    (one target at a time), started at random configurations, on singular, aligned and unreachable poses."""
    solver = ur5[chain_name]
    chain = solver.chain
    joints, _, _ = _ur5_poses(chain, 300, 23)
    poses = [chain.fk(q) for q in joints]
    poses[80:100] = [pin.SE3(p.rotation, p.translation * 1.3) for p in poses[80:100]]
    starts = chain.random(np.random.default_rng(24), len(poses))
    batched = solver.solve_many(poses, starts)
    for index, (pose, start, many) in enumerate(zip(poses, starts, batched, strict=True)):
        single = solver.solve(pose, q0=start)
        assert single.success == many.success
        assert single.reason.split(":")[0] == many.reason.split(":")[0]
        if single.q is not None:
            np.testing.assert_allclose(many.q, single.q, rtol=0, atol=_agreement(joints[index]))
    assert sum(r.success for r in batched) >= 270


class _MissingNearest(ClosedForm):
    """A UR5 closed form whose first four branches are off by 1e-3 rad in every joint for every other
    target: there the nearest branch often misses the screen, and the choice must go on to the next."""

    def __init__(self, form: ClosedForm):
        super().__init__(form.chain)
        self.form = form

    def branches(self, positions, rotations, q0):
        q_all, real = self.form.branches(positions, rotations, q0)
        q_all = q_all.copy()
        q_all[::2, :4] += 1e-3
        return q_all, real

    def fk(self, q):
        return self.form.fk(q)


def test_choice_goes_on_to_the_next_branch_where_the_nearest_misses(ur5):
    """The choice screens only the nearest branch of every target, then sorts and screens further only
    where it missed: the same joints as screening every branch and taking the nearest."""
    solver = ur5["ee"]
    form = _MissingNearest(solver.closed_form("pose"))
    joints, positions, rotations = _ur5_poses(solver.chain, 400, 25)
    starts = joints + np.random.default_rng(26).normal(0.0, 0.3, joints.shape)
    starts = np.clip(starts, solver.chain.lower, solver.chain.upper)
    choice = solver._choose(form, positions, rotations, starts)
    q_all, _, usable = solver._wrapped_by_joint(form, positions, rotations, starts)
    q_all, usable = q_all.transpose(2, 1, 0), usable.T
    residual = solver._screen(form, q_all, positions[:, None], rotations[:, None])[0]
    screened = usable & (residual <= form.screen_tolerance)
    distance = np.where(screened, np.linalg.norm(q_all - starts[:, None], axis=-1), np.inf)
    best = np.argmin(distance, axis=1)
    nearest_missed = np.argmin(np.where(usable, np.linalg.norm(q_all - starts[:, None], axis=-1), np.inf),
                               axis=1) < 4
    assert (nearest_missed[::2] & screened[::2].any(axis=1)).sum() > 50  # the retry path is taken
    np.testing.assert_array_equal(choice.found, screened.any(axis=1))
    found = choice.found
    np.testing.assert_array_equal(choice.q[found], q_all[np.flatnonzero(found), best[found]])
    reached_p, reached_r = form.fk(choice.q[found])
    np.testing.assert_array_equal(choice.reached_p[found], reached_p)
    np.testing.assert_array_equal(choice.reached_r[found], reached_r)
    assert not choice.q[~found].any() and not choice.reached_p[~found].any()


def test_batch_targets_accepts_what_the_fast_se3_check_accepts(ur5):
    """The vectorised SE3 check decides target by target as ``as_target``'s fast path: rotations and
    positions just inside and just outside each bound (unit columns, orthogonality, det, position)."""
    from wbik.solvers.analytic.batch import _valid_se3
    from wbik.targets import MAX_POSITION, ROTATION_TOLERANCE, plain_pose_matrix

    chain = ur5["ee"].chain
    rng = np.random.default_rng(27)
    poses = [chain.fk(q) for q in chain.random(rng, 40)]
    skew = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    cases = []
    for pose in poses:
        for factor in (0.4, 0.5, 0.6):  # unit columns / orthogonality / det around the tolerance
            cases.append(pin.SE3(pose.rotation * (1.0 + factor * ROTATION_TOLERANCE), pose.translation))
            cases.append(pin.SE3(pose.rotation + 2.0 * factor * ROTATION_TOLERANCE * skew, pose.translation))
        for offset in (-1.0, 0.0, 1e-6):
            cases.append(pin.SE3(pose.rotation, np.array([MAX_POSITION + offset, 0.0, 0.0])))
    cases.append(pin.SE3(-poses[0].rotation, poses[0].translation))
    cases.append(pin.SE3(poses[0].rotation, np.array([np.nan, 0.0, 0.0])))
    for case in cases:
        assert _valid_se3(case.homogeneous[None]) == (plain_pose_matrix(case) is not None)
    accepted = [case for case in cases if plain_pose_matrix(case) is not None]
    assert 0 < len(accepted) < len(cases)
    assert _valid_se3(np.array([case.homogeneous for case in accepted]))


def test_planar_2r_elbow_gives_the_second_link_direction():
    """(x + i y)((b + a c2) + i a s2) points along q1 + q2 (what the UR family's q4 uses instead of
    cos and sin of q1 + q2), with a positive length, on both elbow branches."""
    rng = np.random.default_rng(28)
    first, second = -0.425, -0.39225
    x, y = rng.uniform(-0.8, 0.8, (2, 400))
    angle1, angle2, real, cosines, sines = planar_2r_elbow(x, y, first, second)
    np.testing.assert_array_equal(np.stack(planar_2r(x, y, first, second)[:2]), np.stack((angle1, angle2)))
    along, across = second + first * cosines, first * sines
    direction = (x[:, None] * along - y[:, None] * across, y[:, None] * along + x[:, None] * across)
    length = np.hypot(*direction)
    assert np.all(length[real] > 0.0)
    total = angle1 + angle2
    np.testing.assert_allclose(direction[0][real] / length[real], np.cos(total)[real], rtol=0, atol=1e-14)
    np.testing.assert_allclose(direction[1][real] / length[real], np.sin(total)[real], rtol=0, atol=1e-14)
    assert 0 < real.sum() < real.size


def test_transpose_times_equals_einsum():
    """The batched check's R*^T R, written out, gives einsum's bits (the reported rotation errors)."""
    from wbik.solvers.analytic.aligned import times

    rng = np.random.default_rng(29)
    first, second = (np.array([pin.rpy.rpyToMatrix(*rpy) for rpy in rng.normal(size=(300, 3))])
                     for _ in range(2))
    np.testing.assert_array_equal(times(np.swapaxes(first, 1, 2), second),
                                  np.einsum("bji,bjk->bik", first, second))
