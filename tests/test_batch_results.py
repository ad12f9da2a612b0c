"""``solve_many`` returns :class:`wbik.IKResults`: the answers of ``solve`` in order, each field also as a
column; a closed form's batch keeps its solved rows as arrays and builds each IKResult when read (then
keeps it); the batch may be one array of poses or positions, with the answers and errors of a list."""

from __future__ import annotations

import pickle

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import InvalidTargetError
from wbik.solvers.batch_results import IKResults


def _same(first, second) -> None:
    assert len(first) == len(second)
    for a, b in zip(first, second, strict=True):
        assert (a.success, a.reason, a.iterations, a.method) == (b.success, b.reason, b.iterations, b.method)
        assert (a.q is None and b.q is None) or np.array_equal(a.q, b.q)
        assert np.array_equal(a.position_error_xyz, b.position_error_xyz, equal_nan=True)
        assert np.array_equal(a.rotation_error_xyz, b.rotation_error_xyz, equal_nan=True)
        assert a.extra == b.extra


@pytest.fixture(scope="module")
def ur5():
    return wbik.solver("analytic", "ur5", chain="ee")


def _batch(solver, rng, count: int = 40) -> list[pin.SE3]:
    """FK poses of random joints, the sixth moved out of reach."""
    poses = [solver.chain.fk(q) for q in solver.chain.random(rng, count)]
    far = poses[5].copy()
    far.translation = far.translation + np.array([5.0, 0.0, 0.0])
    poses[5] = far
    return poses


def test_the_answers_are_those_of_solve_in_order(ur5, rng):
    poses = _batch(ur5, rng)
    answers = ur5.solve_many(poses)
    assert isinstance(answers, IKResults) and len(answers) == len(poses)
    assert not answers[5].success and answers[5].reason and answers[5].q is None
    for batched, pose in zip(answers, poses, strict=True):
        single = ur5.solve(pose)
        assert batched.success == single.success
        if single.success:
            assert np.allclose(batched.q, single.q, atol=1e-9)
            assert batched.extra["batched"] and batched.extra["branches"] == single.extra["branches"]


def test_the_columns_are_the_answers_fields(ur5, rng):
    answers = ur5.solve_many(_batch(ur5, rng))
    rows = list(answers)  # every answer built
    assert answers.success.tolist() == [a.success for a in rows]
    assert answers.reasons == [a.reason for a in rows]
    for name in ("position_error", "rotation_error"):
        assert np.array_equal(getattr(answers, name), [getattr(a, name) for a in rows], equal_nan=True)
    q = answers.q
    assert q.shape == (len(rows), 6)
    for row, answer in zip(q, rows, strict=True):
        assert np.all(np.isnan(row)) if answer.q is None else np.array_equal(row, answer.q)
    fresh = ur5.solve_many(_batch(ur5, np.random.default_rng(7)))  # columns before any answer is built
    assert np.array_equal(fresh.q, np.array([a.q if a.q is not None else np.full(6, np.nan) for a in fresh]),
                          equal_nan=True)


def test_an_answer_is_built_once_and_kept(ur5, rng):
    answers = ur5.solve_many(_batch(ur5, rng))
    first = answers[0]
    first.extra["note"] = "mine"
    assert answers[0] is first and answers[-len(answers)] is first
    assert answers[0].extra["note"] == "mine"
    with pytest.raises(IndexError):
        answers[len(answers)]


def test_slices_pickles_and_joins_keep_the_answers(ur5, rng):
    answers = ur5.solve_many(_batch(ur5, rng))
    _same(answers[3:9], list(answers)[3:9])
    _same(pickle.loads(pickle.dumps(answers)), answers)
    _same(IKResults.joined([answers[:10], answers[10:]]), answers)
    listed = IKResults.of(list(answers))
    _same(IKResults.joined([listed[:7], answers[7:]]), answers)
    fresh = ur5.solve_many(_batch(ur5, np.random.default_rng(5)))  # parts joined before any row is built
    again = ur5.solve_many(_batch(ur5, np.random.default_rng(5)))
    _same(IKResults.joined([fresh[:13], fresh[13:]]), again)
    assert answers == list(answers) and answers != list(answers)[:-1] and IKResults([]) == []


def test_the_joints_column_has_the_chains_width_when_nothing_is_solved():
    far = pin.SE3(np.eye(3), np.array([9.0, 0.0, 0.0]))
    for method in ("analytic", "eaik"):  # (a method's own batch, and answers built one by one)
        solver = wbik.solver(method, "ur5", chain="ee")
        for workers in (1, 2):
            answers = solver.solve_many([far, far], workers=workers)
            assert not answers.success.any() and answers.q.shape == (2, 6) and np.isnan(answers.q).all()


@pytest.mark.parametrize("form", ["array", "list of arrays"])
def test_an_array_of_poses_gives_the_answers_of_the_se3s(ur5, rng, form):
    poses = _batch(ur5, rng)
    matrices = np.array([pose.homogeneous for pose in poses])
    batch = matrices if form == "array" else list(matrices)
    _same(ur5.solve_many(batch), ur5.solve_many(poses))
    _same(ur5.solve_many(batch, workers=2), ur5.solve_many(poses))


def test_an_array_of_positions_gives_the_answers_of_the_vectors(rng):
    solver = wbik.solver("analytic", "arm3r")
    positions = np.array([solver.chain.fk(q).translation for q in solver.chain.random(rng, 30)])
    _same(solver.solve_many(positions), solver.solve_many(list(positions)))


@pytest.mark.parametrize("method", ["analytic", "dls"])
def test_a_bad_row_in_an_array_raises_what_solve_raises(method, rng):
    solver = wbik.solver(method, "ur5", chain="ee")
    matrices = np.array([solver.chain.fk(q).homogeneous for q in solver.chain.random(rng, 4)])
    not_rotation, bad_row, not_finite = matrices.copy(), matrices.copy(), matrices.copy()
    not_rotation[2, :3, :3] *= 1.01
    bad_row[1, 3, 0] = 0.5
    not_finite[3, 0, 3] = np.nan
    for batch, row in ((not_rotation, 2), (bad_row, 1), (not_finite, 3)):
        with pytest.raises(InvalidTargetError) as single:
            solver.solve(batch[row])
        with pytest.raises(InvalidTargetError) as batched:
            solver.solve_many(batch)
        assert type(batched.value) is type(single.value)


def test_an_array_of_other_numbers_takes_the_general_path(ur5, rng):
    """float32 poses and integer positions: converted as ``solve`` converts one target."""
    poses = _batch(ur5, rng)[:6]
    as_float32 = np.array([pose.homogeneous for pose in poses], dtype=np.float32)
    _same(ur5.solve_many(as_float32), ur5.solve_many(list(as_float32)))
    arm = wbik.solver("analytic", "arm3r")
    integers = np.array([[3, 0, 2], [0, 2, 3]])
    _same(arm.solve_many(integers), arm.solve_many(integers.astype(float)))
