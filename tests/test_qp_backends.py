"""The stacked constraint buffers handed to DAQP as they are agree with the general backend call;
the reused DAQP workspaces (warm-started) agree with cold solves; no solution raises a typed error."""

import numpy as np
import pytest

from wbik.errors import NoQPSolutionError
from wbik.qp import available_backends, backends


def solved(function, *args):
    """The minimiser, or None when the call raises NoQPSolutionError."""
    try:
        return function(*args)
    except NoQPSolutionError:
        return None


def random_qp(rng, n=12, inequalities=9, equalities=3):
    M = rng.normal(size=(n, n))
    H = M @ M.T + 0.1 * np.eye(n)
    c = rng.normal(size=n)
    G, h = rng.normal(size=(inequalities, n)), rng.uniform(-0.2, 1.0, inequalities)
    A, b = rng.normal(size=(equalities, n)), rng.normal(scale=0.1, size=equalities)
    lb, ub = -rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    return H, c, G, h, A, b, lb, ub


def stacked(G, h, A, b, lb, ub, capacity=2):
    """Interleaved inequality and equality blocks, from a small capacity (the buffers must grow)."""
    stack = backends.StackedConstraints(lb.size, capacity)
    lower, upper = stack.clear(10.0)
    lower[:], upper[:] = lb, ub
    half = G.shape[0] // 2
    stack.add(G[:half], h[:half])
    stack.add(A[:1], b[:1], equality=True)
    stack.add(G[half:], h[half:])
    stack.add(A[1:], b[1:], equality=True)
    return stack


@pytest.mark.parametrize("seed", range(20))
def test_stacked_daqp_agrees_with_the_general_call(seed):
    rng = np.random.default_rng(seed)
    H, c, G, h, A, b, lb, ub = random_qp(rng)
    general = solved(backends.solve, "daqp", H, c, G, h, A, b, lb, ub)
    fast = solved(backends.solve_stacked, "daqp", H, c, stacked(G, h, A, b, lb, ub))
    assert (general is None) == (fast is None)
    if general is not None:
        np.testing.assert_allclose(fast, general, rtol=0, atol=1e-10)


@pytest.mark.parametrize("backend", [name for name in available_backends() if name != "daqp"])
def test_split_gives_every_backend_the_same_problem(backend):
    rng = np.random.default_rng(7)
    for _ in range(5):
        H, c, G, h, A, b, lb, ub = random_qp(rng)
        stack = stacked(G, h, A, b, lb, ub)
        G2, h2, A2, b2, lb2, ub2 = stack.split()
        np.testing.assert_array_equal(G2, G)
        np.testing.assert_array_equal(h2, h)
        np.testing.assert_array_equal(A2, A)
        np.testing.assert_array_equal(b2, b)
        np.testing.assert_array_equal(lb2, lb)
        np.testing.assert_array_equal(ub2, ub)
        reference = solved(backends.solve, "daqp", H, c, G, h, A, b, lb, ub)
        other = solved(backends.solve_stacked, backend, H, c, stack)
        if reference is not None and other is not None:
            np.testing.assert_allclose(other, reference, atol=1e-5)


def test_a_reused_workspace_agrees_with_cold_solves_on_a_sequence_of_qps():
    """One layout, data changing from QP to QP (as along an IK loop), infeasible ones in between: the
    warm-started workspace gives the cold solve's minimiser, and raises where the cold solve does."""
    rng = np.random.default_rng(11)
    workspace = backends.DaqpWorkspace()
    H, c, G, h, A, b, lb, ub = random_qp(rng)
    compared = failed = 0
    for index in range(60):
        H2 = H + 0.05 * index * np.eye(H.shape[0])
        c2 = c + rng.normal(scale=0.3, size=c.size)
        G2 = G + rng.normal(scale=0.05, size=G.shape)
        h2 = h + rng.normal(scale=0.3, size=h.size)
        if index % 7 == 3:  # two opposite rows that cannot both hold
            G2[1], h2[1] = -G2[0], -h2[0] - 1.0
        stack = stacked(G2, h2, A, b, lb, ub, capacity=G.shape[0] + A.shape[0])
        cold = solved(backends.solve, "daqp", H2, c2, G2, h2, A, b, lb, ub)
        warm = solved(backends.solve_stacked, "daqp", H2, c2, stack, workspace)
        assert (cold is None) == (warm is None), index
        if cold is None:
            failed += 1
        else:
            np.testing.assert_allclose(warm, cold, rtol=0, atol=1e-9)
            compared += 1
    assert compared >= 40 and failed >= 8


@pytest.mark.parametrize("backend", available_backends())
def test_no_solution_raises_with_the_backends_status(backend):
    H, c = np.eye(2), np.zeros(2)
    G, h = np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([-1.0, -1.0])  # x <= -1 and x >= 1
    with pytest.raises(NoQPSolutionError) as caught:
        backends.solve(backend, H, c, G, h, None, None, None, None)
    assert caught.value.backend == backend
    assert caught.value.status is not None
    if backend == "daqp":
        assert caught.value.status == -1 and "infeasible" in str(caught.value)


def test_a_repeated_layout_keeps_its_marks_and_a_changed_one_rewrites_them():
    """The stack keeps the sense and the inequalities' lower bounds where a step adds the same kinds of
    rows as the last one; every sequence of adds, growing the buffers on the way, must still give what
    a fresh stack gives."""
    rng = np.random.default_rng(5)
    n = 4
    reused = backends.StackedConstraints(n, capacity=1)
    sequences = [[(2, True), (3, False)], [(2, True), (3, False)], [(3, False), (2, True)],
                 [(3, False), (2, True), (1, False)], [(3, False)], [(1, True), (4, True), (2, False)]]
    for sequence in sequences:
        fresh = backends.StackedConstraints(n, capacity=1)
        reused.clear(1.0)
        fresh.clear(1.0)
        for count, equality in sequence:
            matrix, upper = rng.normal(size=(count, n)), rng.normal(size=count)
            reused.add(matrix, upper, equality)
            fresh.add(matrix, upper, equality)
        for name in ("matrix", "upper", "lower", "sense"):
            assert np.array_equal(getattr(reused, name), getattr(fresh, name)), (sequence, name)


def test_the_views_in_use_follow_rows_and_layout():
    """``in_use`` (what the DAQP workspace hands DAQP) is made again when the rows or their kinds change,
    and equals the properties every time."""
    stack = backends.StackedConstraints(3, capacity=1)
    for sequence in ([(2, True)], [(2, True)], [(2, False)], [(2, False), (1, True)], [(2, False)]):
        stack.clear(1.0)
        for count, equality in sequence:
            stack.add(np.ones((count, 3)), np.full(count, 0.5), equality)
        matrix, upper, lower, sense, key = stack.in_use()
        assert np.array_equal(matrix, stack.matrix) and np.array_equal(upper, stack.upper)
        assert np.array_equal(lower, stack.lower) and np.array_equal(sense, stack.sense)
        assert key == stack.sense.tobytes()
