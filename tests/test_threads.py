"""One solver shared by 4 threads gives the answers of a sequential run.

Threads switch every microsecond here (``sys.setswitchinterval``), far more often than by default,
so that a solver writing shared Pinocchio Data or shared working objects would mix up kinematics
between calls. Methods whose loop is ours, and KDL's single attempt, are deterministic: their joints
must match the sequential run exactly. Methods budgeted by a wall clock inside another library
(TRAC-IK, KDL restarts, PlaCo) may legitimately change a verdict when a thread waits: for them
every reported success is re-checked here by FK, independently of the solver, and the number solved
must stay close to the sequential run.
"""

from __future__ import annotations

import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pinocchio as pin
import pytest

import wbik

DETERMINISTIC = ("analytic", "newton", "dls", "bounded_lm", "qp", "kdl")
WALL_CLOCK = ("kdl_restarts", "trac_ik", "placo")


@pytest.fixture(scope="module")
def ur5_case():
    robot = wbik.load("ur5")
    chain = robot.chain("arm")
    rng = np.random.default_rng(7)
    targets = [chain.fk(q) for q in chain.random(rng, 48)]
    targets.append(pin.SE3(np.eye(3), np.array([3.0, 0.0, 0.0])))  # out of reach: the longest calls
    return robot, chain, targets


@pytest.fixture
def frequent_switching():
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(previous)


def _true_success(chain, target, q) -> bool:
    """The shared check recomputed from scratch with a fresh Data (not the solver's)."""
    data = chain.model.createData()
    pin.framesForwardKinematics(chain.model, data, q)
    reached = chain.base_placement.inverse() * data.oMf[chain.tip_id]
    position = np.linalg.norm(reached.translation - target.translation)
    rotation = np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))
    return position <= 1e-6 and rotation <= 1e-6


@pytest.mark.parametrize("method", DETERMINISTIC + WALL_CLOCK)
def test_four_threads_on_one_solver_match_the_sequential_run(method, ur5_case, frequent_switching):
    robot, chain, targets = ur5_case
    options = {"timeout_s": 0.3} if method in WALL_CLOCK else {}  # ample: threads share one GIL
    solver = wbik.solver(method, robot, chain="arm", **options)
    sequential = [solver.solve(target) for target in targets]
    with ThreadPoolExecutor(max_workers=4) as pool:
        threaded = list(pool.map(solver.solve, targets))
    for target, alone, shared in zip(targets, sequential, threaded, strict=True):
        if shared.success:
            assert _true_success(chain, target, shared.q), f"{method}: a false success under threads"
        if method in DETERMINISTIC:
            assert shared.success == alone.success, (method, alone.reason, shared.reason)
            if alone.q is None:
                assert shared.q is None
            else:
                np.testing.assert_array_equal(shared.q, alone.q)
    if method in WALL_CLOCK:
        solved_alone = sum(r.success for r in sequential)
        solved_shared = sum(r.success for r in threaded)
        assert solved_shared >= solved_alone - 3, (method, solved_alone, solved_shared)
        for alone, shared in zip(sequential, threaded, strict=True):  # a lost pose ran out of time,
            if alone.success and not shared.success:                  # it was not misled
                assert "budget" in shared.reason or "within" in shared.reason, shared.reason


def test_separate_solvers_on_one_robot_do_not_disturb_each_other(ur5_case, frequent_switching):
    """Two methods on one Robot (one Chain, so one model) from two threads at once."""
    robot, _, targets = ur5_case
    first = wbik.solver("dls", robot, chain="arm")
    second = wbik.solver("newton", robot, chain="arm")
    expected = ([first.solve(t).q for t in targets], [second.solve(t).q for t in targets])
    with ThreadPoolExecutor(max_workers=2) as pool:
        jobs = [pool.submit(lambda s=s: [s.solve(t).q for t in targets]) for s in (first, second)]
        got = [job.result() for job in jobs]
    for want, have in zip(expected, got, strict=True):
        for a, b in zip(want, have, strict=True):
            np.testing.assert_array_equal(a, b)


def test_answer_does_not_depend_on_the_order_of_calls(ur5_case):
    """Restarts draw from a stream seeded by (seed, target, q0): reversing the calls changes nothing."""
    robot, _, targets = ur5_case
    solver = wbik.solver("bounded_lm", robot, chain="arm", max_iterations=300)
    forward = [solver.solve(t) for t in targets]
    backward = [solver.solve(t) for t in reversed(targets)][::-1]
    for a, b in zip(forward, backward, strict=True):
        assert a.success == b.success
        np.testing.assert_array_equal(a.q, b.q)
