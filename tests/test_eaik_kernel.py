"""The eaik method's compiled choice (``wbik/kernels/_eaik.c``) against its Python twin
(``wbik/kernels/eaik.py``).

Both must return the same bits: the same rows in the same order from ``order`` and the same choice, pose
and errors from ``choose``, on EAIK's branches of FK poses from random starts, starts on the joint
limits, branches moved onto the limits and onto +-pi and 2 pi wraps, perturbed branches, NaN and
infinite joints, and targets at the screen's threshold. The form's FK is the model's, its errors are
Pinocchio's to rounding, and ``evaluate_screened`` gives ``evaluate``'s verdict.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.kernels import eaik as eaik_kernel
from wbik.solvers.check import evaluate, evaluate_screened
from wbik.solvers.result import Candidate
from wbik.targets import as_target

pytest.importorskip("eaik")
pytestmark = pytest.mark.skipif(eaik_kernel.choose_compiled is None, reason="the C extension is not built")


@pytest.fixture(scope="module", params=["ur5.ee", "bioloid.right_leg"])
def solver(request):
    robot, chain = request.param.split(".")
    return wbik.solver("eaik", wbik.load(robot), chain)


def _orders(solver, q_all, q0):
    rows = []
    for order in (eaik_kernel.order_python, eaik_kernel.order_compiled):
        out = np.full((len(q_all), len(q0)), -7.0)
        count = order(solver._params, q_all, q0, out)
        rows.append(out[:count].copy())
    return rows


def _cases(solver, count=300):
    chain = solver.chain
    rng = np.random.default_rng(21)
    lower, upper = chain.lower, chain.upper
    for index, q in enumerate(chain.random(rng, count)):
        q_all = solver._library_branches(as_target(chain.fk(q)))
        q0 = chain.random(rng, 1)[0]
        if index % 4 == 1:
            q0 = np.where(rng.random(chain.nq) < 0.5, lower, upper)  # starts on the limits
        if index % 4 == 2:  # branches on the limits, just past them, on +-pi, a turn away
            q_all = q_all.copy()
            picks = rng.integers(0, 6, q_all.shape)
            edge = np.choose(picks, [lower + 0 * q_all, upper + 0 * q_all, lower - 5e-10 + 0 * q_all,
                                     upper + 5e-10 + 0 * q_all, np.pi + 0 * q_all, -np.pi + 0 * q_all])
            moved = rng.random(q_all.shape) < 0.3
            q_all[moved] = edge[moved]
            q_all += 2 * np.pi * rng.integers(-2, 3, q_all.shape) * (rng.random(q_all.shape) < 0.3)
        if index % 4 == 3:  # perturbed by a few ulps to a micro-radian
            q_all = q_all * (1 + rng.choice([0.0, 1e-16, -1e-16, 1e-9], q_all.shape)) + \
                rng.choice([0.0, 1e-12, -1e-6], q_all.shape)
        yield np.asarray(q_all, dtype=float), q0


def test_order_twins_give_the_same_bits(solver):
    for q_all, q0 in _cases(solver):
        python, compiled = _orders(solver, q_all, q0)
        assert python.tobytes() == compiled.tobytes()


def test_order_twins_with_nan_inf_far_and_empty_branches(solver):
    rng = np.random.default_rng(5)
    n = solver.chain.nq
    for _ in range(200):
        q_all = rng.uniform(-9.0, 9.0, (8, n))
        q_all[rng.random((8, n)) < 0.05] = np.nan
        q_all[rng.random((8, n)) < 0.05] = np.inf
        q_all[rng.random((8, n)) < 0.02] = 1e300
        q0 = solver.chain.random(rng, 1)[0]
        python, compiled = _orders(solver, q_all, q0)
        assert python.tobytes() == compiled.tobytes()
        assert np.all(np.isfinite(compiled))
    python, compiled = _orders(solver, np.empty((0, n)), solver.chain.nominal)
    assert len(python) == len(compiled) == 0


def test_order_is_the_distance_order_inside_the_limits(solver):
    """The rows come out nearest first and inside the limits."""
    chain = solver.chain
    for q_all, q0 in _cases(solver, 100):
        _, rows = _orders(solver, q_all, q0)
        distances = [float(np.sum((row - q0) ** 2)) for row in rows]
        assert all(a <= b + 1e-9 for a, b in zip(distances, distances[1:], strict=False))
        assert np.all(rows >= chain.lower) and np.all(rows <= chain.upper)


def _chosen(solver, q_all, q0, target):
    outs = []
    for choose in (eaik_kernel.choose_python, eaik_kernel.choose_compiled):
        out = np.full(len(q0) + 24, -7.0)
        found = choose(solver._params, q_all, q0, target, out)
        outs.append((found, out))
    return outs


def test_choose_twins_give_the_same_bits(solver):
    chain = solver.chain
    found_any = 0
    for index, (q_all, q0) in enumerate(_cases(solver, 200)):
        target = chain.fk(q_all[0] if index % 2 and np.all(np.isfinite(q_all[0])) else chain.random(
            np.random.default_rng(index), 1)[0]).homogeneous
        (found_python, python), (found_compiled, compiled) = _chosen(solver, q_all, q0, target)
        assert found_python == found_compiled
        assert python.tobytes() == compiled.tobytes()
        found_any += found_compiled
    assert found_any >= 40  # the found path is exercised, not only the refusals


def test_choose_twins_agree_at_the_screens_threshold(solver):
    chain = solver.chain
    rng = np.random.default_rng(8)
    verdicts = set()
    for q in chain.random(rng, 100):
        reached = chain.fk(q)
        for size in (0.0, 3e-8, 9.9e-8, 1e-7, 1.01e-7, 3e-7):
            for motion in (np.r_[rng.normal(size=3), 0, 0, 0], np.r_[0, 0, 0, rng.normal(size=3)]):
                step = motion / np.linalg.norm(motion) * size
                target = (reached * pin.exp6(pin.Motion(step))).homogeneous
                (found_python, python), (found_compiled, compiled) = _chosen(solver, q[None], q, target)
                assert found_python == found_compiled and python.tobytes() == compiled.tobytes()
                verdicts.add((size, found_compiled))
    assert (0.0, 1) in verdicts and (3e-7, 0) in verdicts  # both sides of the threshold are reached
    nan = np.full((4, 4), np.nan)
    q = chain.nominal
    assert _chosen(solver, q[None], q, nan)[1][0] == 0 == _chosen(solver, q[None], q, nan)[0][0]


def test_the_forms_fk_and_errors_are_the_models(solver):
    """choose's pose is the model's FK to rounding, and its errors are evaluate's (Pinocchio's log3)."""
    chain = solver.chain
    rng = np.random.default_rng(4)
    for q in chain.random(rng, 100):
        target = wbik.targets.as_target(chain.fk(q) * pin.exp6(pin.Motion(rng.normal(0, 2e-8, 6))))
        out = np.empty(chain.nq + 24)
        assert eaik_kernel.choose_compiled(solver._params, q[None], q, target.rotation.base, out) == 1
        np.testing.assert_allclose(out[chain.nq:chain.nq + 16].reshape(4, 4), chain.fk(q).homogeneous,
                                   rtol=0, atol=1e-14)
        reference = evaluate(chain, target, Candidate(q, 1), solver.tolerances, 0.0, "eaik")
        errors = out[chain.nq + 16:]
        np.testing.assert_allclose(errors[:3], reference.position_error_xyz, rtol=0, atol=1e-15)
        np.testing.assert_allclose(errors[3:6], reference.rotation_error_xyz, rtol=1e-7, atol=1e-15)
        np.testing.assert_allclose(errors[6:], [reference.position_error, reference.rotation_error],
                                   rtol=1e-7, atol=1e-15)


def test_kernel_refuses_wrong_arguments(solver):
    n = solver.chain.nq
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(solver._params, np.zeros((8, n)), np.zeros(n), np.zeros((2, n)))
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(np.zeros(2 + 2 * n), np.zeros((8, n)), np.zeros(n), np.zeros((8, n)))
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(solver._params, np.zeros((8, n + 1)), np.zeros(n), np.zeros((8, n + 1)))
    with pytest.raises(TypeError):
        eaik_kernel.choose_compiled(solver._params[:-8], np.zeros((8, n)), np.zeros(n), np.eye(4),
                                    np.zeros(n + 24))
    with pytest.raises(TypeError):
        eaik_kernel.choose_compiled(solver._params, np.zeros((8, n)), np.zeros(n), np.eye(3),
                                    np.zeros(n + 24))
    with pytest.raises(TypeError):
        eaik_kernel.choose_compiled(solver._params, np.zeros((8, n)), np.zeros(n), np.eye(4),
                                    np.zeros(n + 23))


def test_screened_gives_the_shared_checks_verdict(solver):
    """evaluate_screened on choose's output gives evaluate's verdict, joints and reason, its errors to
    rounding: within the tolerances, and failing tight ones (then it is evaluate's result itself)."""
    chain = solver.chain
    rng = np.random.default_rng(2)
    tight = wbik.Tolerances(position=1e-15, rotation=1e-15)
    for q in chain.random(rng, 100):
        target = wbik.targets.as_target(chain.fk(q) * pin.exp6(pin.Motion(rng.normal(0, 2e-8, 6))))
        out = np.empty(chain.nq + 24)
        assert eaik_kernel.choose_compiled(solver._params, q[None], q, target.rotation.base, out) == 1
        for tolerances in (solver.tolerances, tight):
            extra = {"branches": 1}
            plain = evaluate(chain, target, Candidate(q, 1, extra=extra), tolerances, 1.0, "eaik")
            fast = evaluate_screened(chain, target, out, extra, tolerances, 1.0, "eaik")
            assert (fast.success, fast.reason, fast.iterations, fast.method, fast.extra, fast.time_s) == \
                (plain.success, plain.reason, plain.iterations, plain.method, plain.extra, plain.time_s)
            assert fast.q.tobytes() == plain.q.tobytes()
            np.testing.assert_allclose(fast.rotation_error_xyz, plain.rotation_error_xyz, rtol=1e-7,
                                       atol=1e-15)
            np.testing.assert_allclose(fast.position_error_xyz, plain.position_error_xyz, rtol=0,
                                       atol=1e-15)


@pytest.mark.parametrize("setting", ["1", "eaik", "pose,eaik"])
def test_solver_runs_the_python_twin_when_asked(monkeypatch, setting):
    monkeypatch.setenv("WBIK_PURE_PYTHON", setting)
    solver = wbik.solver("eaik", wbik.load("ur5"), "ee")
    assert solver._kernel_choose is eaik_kernel.choose_python
    python_result = solver.solve(solver.chain.fk(solver.chain.nominal))
    monkeypatch.setenv("WBIK_PURE_PYTHON", "pose,ur_type")
    solver = wbik.solver("eaik", wbik.load("ur5"), "ee")
    assert solver._kernel_choose is eaik_kernel.choose_compiled
    compiled_result = solver.solve(solver.chain.fk(solver.chain.nominal))
    assert python_result.success and compiled_result.success
    assert python_result.q.tobytes() == compiled_result.q.tobytes()


def test_the_held_joint_search_choice_twins_agree_on_seven_joints_and_many_branches(monkeypatch):
    """The held-joint search of a 7-joint arm hands the choice every real branch of its first batch (up to
    256 rows of 7 joints): both twins give the same bits, and ``solve`` gives the same answers with either."""
    robot = wbik.load("example-robot-data:panda")
    solver = wbik.solver("analytic", robot, base="panda_link0", tip="panda_link8")
    search = solver.closed_form("pose").search
    chain = solver.chain
    rows_seen, found = 0, 0
    for index, q in enumerate(chain.random(np.random.default_rng(11), 40)):
        target = chain.fk(q)
        q0 = chain.nominal if index % 2 else q + 0.3
        values = np.concatenate(([q0[search.form.index]], search.form.grid))
        raw, real = search.form.branches_at(target.translation[None], target.rotation[None], q0[None],
                                            values[None], exact=True)
        branches = raw[0][real[0] & np.all(np.isfinite(raw[0]), axis=-1)]
        rows_seen = max(rows_seen, len(branches))
        outs = []
        for choose in (eaik_kernel.choose_python, eaik_kernel.choose_compiled):
            out = np.full(chain.nq + 24, -7.0)
            outs.append((choose(search.params, branches, q0, target.homogeneous, out), out.tobytes()))
        assert outs[0] == outs[1]
        found += outs[0][0]
    assert rows_seen > 64 and found >= 35  # more rows than one EAIK call gives, and the found path runs
    targets = [chain.fk(q) for q in chain.random(np.random.default_rng(12), 20)]
    compiled = [solver.solve(t, chain.nominal).q for t in targets]
    monkeypatch.setattr(search, "choose", eaik_kernel.choose_python)
    python = [solver.solve(t, chain.nominal).q for t in targets]
    assert all(np.array_equal(a, b) for a, b in zip(compiled, python, strict=True))
