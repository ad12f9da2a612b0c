"""The eaik method's compiled choice (``_eaik_kernel.c``) against its Python twin (``eaik_kernel.py``).

Both must return the same bits: the same rows in the same order from ``order`` and the same verdict from
``screen``, on EAIK's branches of FK poses from random starts, starts on the joint limits, branches
moved onto the limits and onto +-pi and 2 pi wraps, perturbed branches, NaN and infinite joints, and
the screen at its threshold. ``evaluate_reached`` and ``evaluate``'s ``reached`` give ``evaluate``'s
IKResult.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.solvers.analytic import eaik_kernel
from wbik.solvers.base import Candidate
from wbik.solvers.base import evaluate
from wbik.solvers.base import evaluate_reached

pytest.importorskip("eaik")
pytestmark = pytest.mark.skipif(not eaik_kernel.built(), reason="the C extension is not built here")


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
        q_all = solver.raw_branches(chain.fk(q))
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


def test_screen_twins_give_the_same_verdict_at_the_threshold(solver):
    chain = solver.chain
    rng = np.random.default_rng(8)
    for q in chain.random(rng, 200):
        reached = chain.fk(q).homogeneous
        for size in (0.0, 3e-8, 9.9e-8, 1e-7, 1.01e-7, 3e-7):
            for motion in (np.r_[rng.normal(size=3), 0, 0, 0], np.r_[0, 0, 0, rng.normal(size=3)]):
                step = motion / np.linalg.norm(motion) * size
                target = pin.SE3(reached) * pin.exp6(pin.Motion(step))
                position, rotation = target.translation.copy(), target.rotation.copy()
                verdicts = {screen(reached, position, rotation, 1e-7)
                            for screen in (eaik_kernel.screen_python, eaik_kernel.screen_compiled)}
                assert len(verdicts) == 1
    nan = np.full((4, 4), np.nan)
    assert eaik_kernel.screen_compiled(nan, np.zeros(3), np.eye(3), 1e-7) is False
    assert eaik_kernel.screen_python(nan, np.zeros(3), np.eye(3), 1e-7) is False


def test_kernel_refuses_wrong_arguments(solver):
    n = solver.chain.nq
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(solver._params, np.zeros((8, n)), np.zeros(n), np.zeros((2, n)))
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(np.zeros(2 + 2 * n), np.zeros((8, n)), np.zeros(n), np.zeros((8, n)))
    with pytest.raises(TypeError):
        eaik_kernel.order_compiled(solver._params, np.zeros((8, n + 1)), np.zeros(n), np.zeros((8, n + 1)))


def _same_result(a, b):
    assert (a.q is None) == (b.q is None)
    if a.q is not None:
        assert a.q.tobytes() == b.q.tobytes()
    assert (a.success, a.reason, a.iterations, a.method, a.extra, a.time_s) == \
        (b.success, b.reason, b.iterations, b.method, b.extra, b.time_s)
    for name in ("position_error", "rotation_error"):
        assert np.float64(getattr(a, name)).tobytes() == np.float64(getattr(b, name)).tobytes()
    for name in ("position_error_xyz", "rotation_error_xyz"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()


def test_reached_gives_the_shared_checks_result(solver):
    """evaluate with the placement, and evaluate_reached, give evaluate's IKResult: inside the limits,
    outside (the FK is then recomputed), failing the tolerances, NaN joints."""
    chain = solver.chain
    rng = np.random.default_rng(2)
    tight = wbik.Tolerances(position=1e-15, rotation=1e-15)
    for q in chain.random(rng, 100):
        target = wbik.targets.as_target(chain.fk(q) * pin.exp6(pin.Motion(rng.normal(0, 1e-7, 6))))
        for joints in (q, q + 1e-4, np.where(rng.random(chain.nq) < 0.5, chain.upper + 0.1, q),
                       np.where(rng.random(chain.nq) < 0.2, np.nan, q)):
            reached = chain.fk(joints).homogeneous
            for tolerances in (solver.tolerances, tight):
                extra = {"branches": 8}
                plain = evaluate(chain, target, Candidate(joints, 1, extra=extra), tolerances, 1.0, "eaik")
                placed = evaluate(chain, target, Candidate(joints, 1, extra=extra), tolerances, 1.0, "eaik",
                                  reached)
                fast = evaluate_reached(chain, target, joints, reached, extra, tolerances, 1.0, "eaik")
                _same_result(placed, plain)
                _same_result(fast, plain)


def test_solver_runs_the_python_twin_when_asked(monkeypatch):
    monkeypatch.setenv("WBIK_PURE_PYTHON", "1")
    solver = wbik.solver("eaik", wbik.load("ur5"), "ee")
    assert solver._order is eaik_kernel.order_python and solver._screen is eaik_kernel.screen_python
    monkeypatch.delenv("WBIK_PURE_PYTHON")
    solver = wbik.solver("eaik", wbik.load("ur5"), "ee")
    assert solver._order is eaik_kernel.order_compiled and math.isfinite(solver.solve(
        solver.chain.fk(solver.chain.nominal)).position_error)
