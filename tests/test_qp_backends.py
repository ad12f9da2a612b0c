"""The stacked constraint buffers handed to DAQP as they are agree with the general backend call."""

import numpy as np
import pytest

from wbik.qp import available_backends, backends


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
    general = backends.solve("daqp", H, c, G, h, A, b, lb, ub)
    fast = backends.solve_stacked("daqp", H, c, stacked(G, h, A, b, lb, ub))
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
        reference = backends.solve("daqp", H, c, G, h, A, b, lb, ub)
        other = backends.solve_stacked(backend, H, c, stack)
        if reference is not None and other is not None:
            np.testing.assert_allclose(other, reference, atol=1e-5)
