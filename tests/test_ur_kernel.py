"""The compiled UR-type choice (``wbik/kernels/_ur_type.c``) against its twin, the vectorised choice.

Both take the same decisions (branch, status, the distinct branches of ``solve_all``) on random poses, at
the wrist singularity, with the elbow stretched, at the joint limits and under tiny relative perturbations
(hypothesis); their joints are the same bits where NumPy's arctan2 and arccos are libm's (checked in a
child process without NumPy's AVX-512 code), else within ``TWIN_TOLERANCE``. The extension is built by
the README's set-up (``pip install -e .``; tests/test_compiled.py checks that it is).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from compiled_twins import (
    SINGULAR_TOLERANCE,
    TWIN_TOLERANCE,
    assert_same_bits_without_avx512,
    assert_twins_agree,
    compared_with_its_twin,
    compiled_nearest,
    numpy_is_libm,
)
from hypothesis import given, settings
from hypothesis import strategies as st

import wbik
from wbik.kernels.twins import PURE_PYTHON_VARIABLE
from wbik.solvers.analytic import ur_type
from wbik.solvers.analytic.closed_form import no_solution_reason
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate
from wbik.targets import as_target

pytestmark = compared_with_its_twin(ur_type._ur_kernel)

CHAINS = ["ee", "arm"]
"""UR5 chains: ``ee`` is the family's own frame, ``arm`` adds the riveting tool (the kernel's tool)."""
BITS = numpy_is_libm()


@pytest.fixture(scope="module")
def solvers():
    """Analytic solvers with their closed forms built with the kernel (even in a WBIK_PURE_PYTHON=1 run)."""
    robot = wbik.load("ur5")
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv(PURE_PYTHON_VARIABLE, raising=False)
        solvers = {name: wbik.solver("analytic", robot, chain=name) for name in CHAINS}
        for solver in solvers.values():
            solver.closed_form("pose")
    return solvers


def test_every_ur_form_has_the_kernel_where_it_is_built(solvers):
    assert all(solver.closed_form("pose").kernel is not None for solver in solvers.values())


def tolerance(joints: np.ndarray) -> float:
    """Kernel against twin off libm (compiled_twins): SINGULAR_TOLERANCE at a stretched elbow (q3)."""
    return SINGULAR_TOLERANCE if abs(np.sin(joints[2])) < 1e-6 else TWIN_TOLERANCE


def compiled_reason(solver, target, q0) -> str:
    """The kernel's failure reason, as ``AnalyticSolver._solve`` reads it ("" where it picks a branch)."""
    q, status = compiled_nearest(solver.closed_form("pose").kernel, target.position, target.rotation, q0)
    return "" if q is not None else no_solution_reason(status != 0, status == -2)


def special_joints(chain, rng: np.random.Generator, count: int) -> np.ndarray:
    """Random joints with every third at the wrist singularity (q5 = 0 or pi), every fifth with the
    elbow stretched (q3 = 0) and every seventh with a joint on its limit."""
    joints = chain.random(rng, count)
    joints[::3, 4] = rng.choice([0.0, np.pi, -np.pi], size=len(joints[::3]))
    joints[::5, 2] = 0.0
    for row in range(0, count, 7):
        joint = rng.integers(6)
        joints[row, joint] = chain.lower[joint] if rng.random() < 0.5 else chain.upper[joint]
    return joints


@pytest.mark.numerics
@pytest.mark.parametrize("chain_name", CHAINS)
def test_kernel_is_its_twin(solvers, chain_name):
    solver = solvers[chain_name]
    chain = solver.chain
    rng = np.random.default_rng(2026)
    joints = special_joints(chain, rng, 1500)
    starts = chain.random(rng, len(joints))
    starts[::2] = chain.nominal  # solve's default start
    gaps = [assert_twins_agree(solver, as_target(chain.fk(q)), q0, BITS, tolerance(q))
            for q, q0 in zip(joints, starts, strict=True)]
    assert max(gaps) > 0.0 or BITS  # AVX-512's arctan2 and arccos do differ from libm's somewhere


def test_kernel_is_its_twin_bit_for_bit_where_numpy_is_libm():
    """NumPy without its AVX-512 code (libm's arctan2 and arccos): the kernel's joints are its twin's bits."""
    assert_same_bits_without_avx512([("ur5", name) for name in CHAINS])


@pytest.mark.numerics
@pytest.mark.parametrize("chain_name", CHAINS)
def test_kernel_agrees_on_unreachable_targets(solvers, chain_name):
    """Failures: too far, and inside the cylinder around the base axis the wrist cannot enter."""
    solver = solvers[chain_name]
    chain = solver.chain
    reachable = chain.fk(chain.mid_range)
    rotation = reachable.rotation
    reasons = set()
    for position in ([3.0, 0.0, 0.5], [0.0, 0.0, 0.3], [0.01, 0.02, 0.9], reachable.translation):
        target = as_target(wbik.Target(np.array(position), rotation))
        assert_twins_agree(solver, target, chain.nominal, BITS)
        reasons.add(compiled_reason(solver, target, chain.nominal))
    assert reasons == {"", no_solution_reason(False, False)}  # the reachable pose solved, the rest not


@pytest.mark.numerics
@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), noise=st.floats(-1e-12, 1e-12), chain_name=st.sampled_from(CHAINS))
def test_kernel_bits_under_tiny_relative_noise(solvers, seed, noise, chain_name):
    """A singular pose (wrist aligned, elbow stretched) nudged by a relative 1e-12: kernel and twin still
    take every decision alike (the singularity, the cosine clamps, the limits, the screen)."""
    solver = solvers[chain_name]
    chain = solver.chain
    rng = np.random.default_rng(seed)
    q = chain.random(rng)
    q[4], q[2] = 0.0, 0.0
    pose = chain.fk(q)
    position = pose.translation * (1.0 + noise)
    target = as_target(wbik.Target(position, pose.rotation))
    assert_twins_agree(solver, target, chain.random(rng), BITS, SINGULAR_TOLERANCE)


@pytest.mark.parametrize("chain_name", CHAINS)
def test_kernel_fk_is_the_forms_fk(solvers, chain_name):
    form = solvers[chain_name].closed_form("pose")
    joints = solvers[chain_name].chain.random(np.random.default_rng(8), 200)
    positions, rotations = form.fk(joints)
    for q, position, rotation in zip(joints, positions, rotations, strict=True):
        got_position, got_rotation = form.kernel.fk(q)
        assert got_position.tobytes() == position.tobytes()  # sin, cos and arithmetic: libm's bits
        assert got_rotation.tobytes() == rotation.ravel().tobytes()


@pytest.mark.parametrize("chain_name", CHAINS)
def test_pure_python_switch_runs_the_twin(solvers, monkeypatch, chain_name):
    """WBIK_PURE_PYTHON=ur_type turns the kernel off when a form is built: solve, solve_all and solve_many
    then run the vectorised twin and answer the same."""
    robot = solvers[chain_name].robot
    compiled = solvers[chain_name]
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "ur_type")
    python = wbik.solver("analytic", robot, chain=chain_name)
    assert python.closed_form("pose").kernel is None
    chain = compiled.chain
    poses = [chain.fk(q) for q in chain.random(np.random.default_rng(31), 100)]
    atol = 0.0 if BITS else TWIN_TOLERANCE
    for target in poses:
        ours, theirs = compiled.solve(target), python.solve(target)
        assert (ours.success, ours.reason, ours.extra) == (theirs.success, theirs.reason, theirs.extra)
        np.testing.assert_allclose(ours.q, theirs.q, rtol=0, atol=atol)
        assert len(compiled.solve_all(target)) == len(python.solve_all(target))
    for ours, theirs in zip(compiled.solve_many(poses), python.solve_many(poses), strict=True):
        assert (ours.success, ours.reason, ours.extra) == (theirs.success, theirs.reason, theirs.extra)
        np.testing.assert_allclose(ours.q, theirs.q, rtol=0, atol=atol)
        np.testing.assert_allclose(ours.position_error_xyz, theirs.position_error_xyz, rtol=0, atol=1e-12)


def test_bad_buffers_are_refused_with_a_type_error(solvers):
    kernel = solvers["ee"].closed_form("pose").kernel
    target = as_target(solvers["ee"].chain.fk(solvers["ee"].chain.nominal))
    with pytest.raises(TypeError, match="rotation"):
        compiled_nearest(kernel, target.position, np.eye(2), np.zeros(6))
    with pytest.raises(TypeError, match="reference"):
        compiled_nearest(kernel, target.position, target.rotation, np.zeros(6, dtype=np.float32))
    with pytest.raises(TypeError, match="out"):
        kernel.nearest_into(target.position, target.rotation, np.zeros(6), np.zeros(5))


@pytest.mark.parametrize("chain_name", CHAINS)
def test_solve_all_errors_are_the_shared_checks(solvers, chain_name):
    """solve_all's kernel check (closed-form FK, batch_log3's formula) against the shared check
    (Pinocchio FK and log3) on every branch it returns:
    the same verdict, errors within 1e-10 (the closed-form FK against Pinocchio's)."""
    solver = solvers[chain_name]
    chain = solver.chain
    count = 0
    for q in special_joints(chain, np.random.default_rng(77), 300):
        target = as_target(chain.fk(q))
        for result in solver.solve_all(target):
            shared = evaluate(chain, target, Candidate(result.q.copy(), 1), solver.tolerances, 0.0, "")
            assert shared.success and result.success
            for ours, theirs in ((result.position_error_xyz, shared.position_error_xyz),
                                 (result.rotation_error_xyz, shared.rotation_error_xyz)):
                np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10)  # as the FK test
            assert abs(result.position_error - shared.position_error) <= 1e-10
            assert abs(result.rotation_error - shared.rotation_error) <= 1e-10
            count += 1
    assert count >= 300 * 4  # UR5 poses have 4 to 8 distinct branches inside its +-2 pi limits


@pytest.mark.numerics
@pytest.mark.parametrize("chain_name", CHAINS)
def test_solve_many_is_solve_bit_for_bit(solvers, chain_name):
    """With the kernel, solve_many makes solve's choice for every target (same joints, same reasons,
    unreachable targets among them, one start per target), and its check (closed-form FK) agrees with
    solve's (Pinocchio): same verdict, errors within 1e-10."""
    solver = solvers[chain_name]
    chain = solver.chain
    rng = np.random.default_rng(404)
    poses = [chain.fk(q) for q in special_joints(chain, rng, 400)]
    rotation = poses[0].rotation
    poses[5::50] = [wbik.Target(np.array([3.0, 0.0, 0.5]), rotation)] * len(poses[5::50])  # out of reach
    starts = chain.random(rng, len(poses))
    batch = solver.solve_many(poses, starts)
    # the unreachable ones fail; so do some exact wrist singularities whose start's q6 leaves the
    # wrist centre out of reach (the family keeps q6 of the start there), in both paths alike
    assert len(poses[5::50]) <= sum(not r.success for r in batch) < len(poses) // 10
    for pose, q0, many in zip(poses, starts, batch, strict=True):
        one = solver.solve(pose, q0)
        assert (many.success, many.reason) == (one.success, one.reason)
        assert many.extra == {**one.extra, "batched": True} or not one.success
        if one.q is None:
            assert many.q is None and np.isnan(many.position_error)
            continue
        assert many.q.tobytes() == one.q.tobytes()
        for ours, theirs in ((many.position_error_xyz, one.position_error_xyz),
                             (many.rotation_error_xyz, one.rotation_error_xyz)):
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10)


@pytest.mark.parametrize("chain_name", CHAINS)
def test_solve_all_results_from_the_kernels_arrays(solvers, chain_name):
    """solve_all's IKResults are those of the kernel's distinct branches and errors: every field, in
    order; a tolerance below the errors drops exactly the branches above it; nothing leaks over many
    calls."""
    import gc
    import sys
    import tracemalloc

    from wbik.solvers.result import IKResult, Tolerances
    solver = solvers[chain_name]
    chain = solver.chain
    kernel = solver.closed_form("pose").kernel
    for q in special_joints(chain, np.random.default_rng(5), 60):
        target = as_target(chain.fk(q))
        results = solver.solve_all(target)
        joints, errors = kernel.distinct(target.position, target.rotation, chain.nominal)
        assert len(results) == len(joints)
        for result, row, error in zip(results, joints, errors, strict=True):
            assert type(result) is IKResult
            assert (result.success, result.reason, result.iterations, result.method, result.extra) == \
                (True, "", 1, "analytic", {})
            assert result.q.tobytes() == row.tobytes()
            assert result.position_error_xyz.tobytes() == error[:3].tobytes()
            assert result.rotation_error_xyz.tobytes() == error[3:6].tobytes()
            assert (result.position_error, result.rotation_error) == (error[6], error[7])
            assert 0.0 < result.time_s < 0.5  # seconds (not ns), with room for a preempted call
        cut = float(np.median(errors[:, 7])) if len(errors) > 1 else 0.0
        if cut > 0.0:
            with pytest.MonkeyPatch.context() as patch:
                patch.delenv(PURE_PYTHON_VARIABLE, raising=False)
                strict = wbik.solver("analytic", solver.robot, chain=chain_name,
                                     tolerances=Tolerances(position=1e-6, rotation=cut))
                strict.closed_form("pose")
            expected = [row.tobytes() for row, error in zip(joints, errors, strict=True) if error[7] <= cut]
            assert [r.q.tobytes() for r in strict.solve_all(target)] == expected
    # no leak: every result holds a reference to the method name (a string of this test's own);
    # tracemalloc sees every object allocated (floats, dicts, views)
    target = as_target(chain.fk(chain.mid_range))
    method = "".join(["leak", "-", "check"])
    call = functools.partial(kernel.results, target.position, target.rotation, chain.nominal, method,
                             solver.tolerances)
    assert call()
    gc.collect()
    tracemalloc.start()
    try:
        references = (sys.getrefcount(IKResult), sys.getrefcount(method))
        allocated = tracemalloc.get_traced_memory()[0]
        for _ in range(2000):
            call()
        gc.collect()
        growth = tracemalloc.get_traced_memory()[0] - allocated
    finally:
        tracemalloc.stop()
    assert (sys.getrefcount(IKResult), sys.getrefcount(method)) == references
    assert growth < 20_000, f"{growth} bytes more after 2,000 calls"


def test_the_forms_screen_tolerance_reaches_the_kernel(solvers):
    """A UR form with a screen tolerance of 0 (few branches are that exact): the kernel screens with it, on
    the plain form and through the tool: it refuses branches the default screen keeps, and what it keeps
    reaches the target exactly by the form's FK."""
    from wbik.robot_packages.ur5.closed_form import UR5EndEffector
    from wbik.solvers.analytic.aligned import with_tool

    class Exact(UR5EndEffector):
        screen_tolerance = 0.0

    for chain_name in CHAINS:
        solver = solvers[chain_name]
        chain = solver.chain
        with pytest.MonkeyPatch.context() as patch:
            patch.delenv(PURE_PYTHON_VARIABLE, raising=False)
            form = Exact(chain) if chain_name == "ee" else with_tool(chain, Exact, "ee")
        outcomes = set()
        for q in chain.random(np.random.default_rng(6), 30):
            target = as_target(chain.fk(q))
            got, status = compiled_nearest(form.kernel, target.position, target.rotation, chain.nominal)
            assert solver.solve(target).success  # the default screen keeps a branch
            if got is not None:
                residual = solver._screen(form, got[None], target.position[None], target.rotation[None])[0]
                assert residual[0] == 0.0
            outcomes.add(status if got is None else "found")
        assert -2 in outcomes  # an exact screen refuses branches
