"""The compiled kernels of :mod:`wbik.kernels`: built by the set-up where a C compiler exists, switched
off by ``WBIK_PURE_PYTHON=1``; the SE3 fast-path test giving the Python test's verdict on every matrix,
and the shared check's arithmetic the Python twin's bits (the closed-form kernels' own agreement tests are
in tests/test_ur_kernel.py and tests/test_analytic_golem3.py)."""

from __future__ import annotations

import array
import os
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wbik import targets
from wbik.kernels.twins import PURE_PYTHON_VARIABLE, can_build, pure_python
from wbik.solvers.analytic import stacked_planar, ur_type
from wbik.targets import MAX_POSITION, ROTATION_TOLERANCE

HAS_COMPILER = can_build()
COMPILED_TWIN = pytest.mark.skipif(not HAS_COMPILER, reason="no C compiler here: no compiled twin to compare "
                                   "(the first test checks that it is built wherever one exists)")


def test_the_extensions_are_built_where_a_compiler_exists():
    """The README's set-up (pip install -e .) builds them; without a compiler or the Python headers the
    Python twins run (and the set-up says so)."""
    assert (ur_type._ur_kernel is not None) == HAS_COMPILER
    assert (stacked_planar._stacked_kernel is not None) == HAS_COMPILER
    assert (targets._compiled_accepts_plain_se3 is not None) == HAS_COMPILER
    from wbik import geometry

    assert (geometry._compiled_pose_errors is not None) == HAS_COMPILER
    from wbik.qp import step, tasks

    assert (tasks._FRAME_ROWS is not None) == HAS_COMPILER and (step._QUADRATIC is not None) == HAS_COMPILER
    from wbik.solvers import levenberg_marquardt

    assert (levenberg_marquardt._LM_TRIAL is not None) == HAS_COMPILER
    from wbik.solvers import bounded_lm

    assert (bounded_lm._LM_ATTEMPT is not None) == HAS_COMPILER  # (None too from a stale build: rebuild)
    assert geometry.pose_errors is (geometry._python_pose_errors if pure_python("pose") or not HAS_COMPILER
                                    else geometry._compiled_pose_errors)
    expected = targets._python_accepts_plain_se3 if pure_python("pose") or not HAS_COMPILER else \
        targets._compiled_accepts_plain_se3
    assert targets._accepts_plain_se3 is expected  # WBIK_PURE_PYTHON=1 (a whole-suite run) picks Python


def test_every_kernel_is_in_the_kernels_folder_and_listed():
    """One look finds them all: every C or C++ source of wbik is wbik/kernels/_<name>.c (.cpp), listed in
    wbik.kernels.twins.KERNELS (and built by setup.py under that name), whose Python twins exist."""
    import importlib
    import re
    from pathlib import Path

    from wbik.kernels.twins import KERNELS

    package = Path(importlib.import_module("wbik").__file__).parent
    sources = sorted(path.relative_to(package).with_suffix("").as_posix()
                     for suffix in ("*.c", "*.cpp") for path in package.rglob(suffix))
    names = [kernel.name for kernel in KERNELS]
    assert sources == sorted(f"kernels/_{name}" for name in names)
    setup = (package.parent / "setup.py").read_text(encoding="utf-8")
    listed = re.search(r"KERNELS = \(([^)]*)\)", setup).group(1)
    assert [word.strip().strip('"') for word in listed.split(",")] == names
    for kernel in KERNELS:
        assert kernel.goal_rows
        if HAS_COMPILER:
            assert kernel.extension.__name__ == f"wbik.kernels._{kernel.name}"
        for twin in re.findall(r"(wbik(?:\.\w+)+)", kernel.python_twin):
            parts = twin.split(".")
            cut = max(i for i in range(1, len(parts) + 1) if _importable(".".join(parts[:i])))
            found = importlib.import_module(".".join(parts[:cut]))
            for attribute in parts[cut:]:
                found = getattr(found, attribute)  # AttributeError: a twin the index names is gone


def _importable(module: str) -> bool:
    import importlib

    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


def test_a_kernel_list_switches_those_kernels_only(monkeypatch):
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "eaik, lm_trial")
    assert pure_python("eaik") and pure_python("lm_trial") and not pure_python("pose") and not pure_python()
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "1")
    assert pure_python("pose") and pure_python()
    monkeypatch.setenv(PURE_PYTHON_VARIABLE, "")
    assert not pure_python("pose") and not pure_python()


def test_pure_python_switch_picks_the_python_twins():
    script = ("from wbik import targets; import wbik; "
              "print(targets._accepts_plain_se3 is targets._python_accepts_plain_se3, "
              "wbik.solver('analytic', wbik.load('ur5'), 'ee').closed_form('pose').kernel, "
              "wbik.solver('analytic', wbik.load('golem3'), 'right_arm').closed_form('pose').kernel)")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                         env={**os.environ, PURE_PYTHON_VARIABLE: "1"}).stdout.split()
    assert out == ["True", "None", "None"]


def both_verdicts(matrix: np.ndarray) -> tuple[bool, bool]:
    matrix = np.ascontiguousarray(matrix, dtype=float)
    return (targets._python_accepts_plain_se3(matrix, MAX_POSITION, ROTATION_TOLERANCE),
            targets._compiled_accepts_plain_se3(matrix, MAX_POSITION, ROTATION_TOLERANCE))


def random_pose(rng: np.random.Generator) -> np.ndarray:
    return pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-2.0, 2.0, 3)).homogeneous


@COMPILED_TWIN
@pytest.mark.numerics
def test_se3_check_verdicts_at_every_bound():
    """Rotations scaled, sheared and flipped around each tolerance, positions around the bound, NaN and
    inf: the compiled test and the Python test agree on every matrix, and both verdicts occur."""
    rng = np.random.default_rng(4)
    skew = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    verdicts = set()
    for _ in range(200):
        pose = random_pose(rng)
        cases = []
        for factor in np.linspace(0.3, 0.7, 9):
            scaled, sheared = pose.copy(), pose.copy()
            scaled[:3, :3] *= 1.0 + factor * ROTATION_TOLERANCE
            sheared[:3, :3] += 2.0 * factor * ROTATION_TOLERANCE * skew
            cases += [scaled, sheared]
        for value in (MAX_POSITION - 1.0, MAX_POSITION, MAX_POSITION * (1 + 1e-15), np.nan, np.inf):
            moved = pose.copy()
            moved[rng.integers(3), 3] = value * rng.choice([-1.0, 1.0])
            cases.append(moved)
        flipped = pose.copy()
        flipped[:3, :3] *= -1.0
        cases.append(flipped)
        for case in cases:
            python, compiled = both_verdicts(case)
            assert python == compiled
            verdicts.add(python)
    assert verdicts == {True, False}


@COMPILED_TWIN
@pytest.mark.numerics
@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), exponent=st.floats(-16.0, -5.0))
def test_se3_check_verdicts_under_relative_noise(seed, exponent):
    """A pose with every entry nudged by a relative 10^exponent (around the 1e-6 tolerance and far
    below it): both tests decide alike."""
    rng = np.random.default_rng(seed)
    pose = random_pose(rng)
    pose[:3] *= 1.0 + 10.0 ** exponent * rng.uniform(-1.0, 1.0, (3, 4))
    python, compiled = both_verdicts(pose)
    assert python == compiled


@COMPILED_TWIN
def test_se3_check_reads_strided_matrices_and_refuses_other_buffers():
    pose = random_pose(np.random.default_rng(9))
    fortran = np.asfortranarray(pose)
    assert targets._compiled_accepts_plain_se3(fortran, MAX_POSITION, ROTATION_TOLERANCE)
    with pytest.raises(TypeError, match="4, 4"):
        targets._compiled_accepts_plain_se3(pose[:3], MAX_POSITION, ROTATION_TOLERANCE)
    with pytest.raises(TypeError, match="matrix: expected a float64 array"):
        targets._compiled_accepts_plain_se3(pose.astype(np.float32), MAX_POSITION, ROTATION_TOLERANCE)
    with pytest.raises(TypeError, match="matrix: expected a float64 array, got list"):
        targets._compiled_accepts_plain_se3(pose.tolist(), MAX_POSITION, ROTATION_TOLERANCE)
    with pytest.raises(TypeError, match="tolerance: expected a float, got str"):
        targets._compiled_accepts_plain_se3(pose, MAX_POSITION, "1e-6")


def half_turn_relative(rng: np.random.Generator, reached: pin.SE3, gap: float) -> np.ndarray:
    """A target rotation R* with R*^T R a turn of pi - gap about a random axis."""
    axis = rng.normal(size=3)
    return reached.rotation @ pin.exp3((np.pi - gap) * axis / np.linalg.norm(axis)).T


@COMPILED_TWIN
@pytest.mark.numerics
def test_pose_errors_twins_give_the_same_bits():
    """The shared check's errors (e_p, e_R, |e_p|, |e_R|): compiled and Python twins agree bit for bit on
    random, nearly equal and nearly half-turned poses, with and without a target rotation; e_R is
    Pinocchio's log3 of R*^T R to rounding wherever the twins call their formula exact, and they do not
    call it exact only within 1e-6 of a half turn, where the check takes Pinocchio's."""
    from wbik import geometry

    rng = np.random.default_rng(12)
    for index in range(600):
        reached = pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-2.0, 2.0, 3))
        near = reached * pin.exp6(pin.Motion(10.0 ** rng.uniform(-15, -3) * rng.normal(size=6)))
        target = near if index % 2 else pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-2.0, 2.0, 3))
        rotation = None if index % 5 == 0 else target.rotation
        if index % 3 == 0 and rotation is not None:
            rotation = half_turn_relative(rng, reached, 10.0 ** rng.uniform(-12, -1))
        outputs = []
        for twin in (geometry._python_pose_errors, geometry._compiled_pose_errors):
            errors = np.empty(8)
            *norms, exact = twin(reached.homogeneous, target.translation, rotation, errors[:3], errors[3:6],
                                 None)
            errors[6:] = norms
            outputs.append((exact, errors.tobytes()))
        assert outputs[0] == outputs[1]
        exact, errors = outputs[0][0], np.frombuffer(outputs[0][1])
        np.testing.assert_array_equal(errors[:3], reached.translation - target.translation)
        assert errors[6] == pytest.approx(np.linalg.norm(errors[:3]), rel=1e-15, abs=0.0)
        if rotation is None:
            assert exact and not errors[3:6].any() and errors[7] == 0.0
            continue
        log3 = geometry.rotation_error(reached.rotation, rotation)
        angle_from_pi = np.pi - np.linalg.norm(log3)
        if not 4e-7 < angle_from_pi < 6e-7:  # |vee| = 2 sin(angle) < 1e-6: within 5e-7 of pi (rounding aside)
            assert exact == (angle_from_pi > 5e-7), angle_from_pi
        if exact:
            # the axis from vee carries 1e-16 / sin(angle): tight for converged checks, looser near pi
            angle = np.linalg.norm(log3)
            bound = 1e-14 if index % 2 and index % 3 else 1e-13 * (1.0 + angle) / max(np.sin(angle), 1e-6)
            np.testing.assert_allclose(errors[3:6], log3, rtol=0, atol=bound)
            assert errors[7] == pytest.approx(angle, rel=0, abs=bound)


@pytest.mark.numerics
@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), gap=st.floats(4e-7, 6e-7), noise=st.floats(-1e-12, 1e-12))
def test_the_check_at_its_half_turn_switch_moves_with_its_input(seed, gap, noise):
    """Around the switch between the check's formula and Pinocchio's log3 (|vee| = 1e-6, a turn 5e-7 short
    of pi), turning the reached rotation by up to 1e-12 rad moves e_R by no more than that turn over
    sin(angle) allows, whichever side of the switch either input falls: no verdict hangs on the last bit."""
    import wbik
    from wbik.solvers.check import evaluate
    from wbik.solvers.result import Candidate, Tolerances

    chain = wbik.load("ur5").chain("arm")
    rng = np.random.default_rng(seed)
    q = chain.random(rng)
    reached = chain.fk(q)
    target = wbik.as_target(pin.SE3(half_turn_relative(rng, reached, gap), reached.translation))
    axis = rng.normal(size=3)
    answers = []
    for turn in (0.0, noise):
        moved = reached.homogeneous.copy()
        moved[:3, :3] = moved[:3, :3] @ pin.exp3(turn * axis / np.linalg.norm(axis))
        answers.append(evaluate(chain, target, Candidate(q.copy()), Tolerances(), 0.0, "test",
                                reached=moved))
    first, second = answers
    assert not first.success and not second.success  # a half turn away: both fail, for the same reason
    assert abs(first.rotation_error - second.rotation_error) <= 10.0 * (abs(noise) + 1e-15)
    np.testing.assert_allclose(first.rotation_error_xyz, second.rotation_error_xyz, rtol=0,
                               atol=10.0 * (abs(noise) + 1e-15) / gap)


@pytest.mark.numerics
def test_the_two_sides_of_the_half_turn_switch_agree():
    """Two turns about one axis, 0.1 % either side of the switch (5e-7 short of pi): one takes the check's
    formula, the other Pinocchio's log3, and their e_R differ by the turns' own difference."""
    from wbik import geometry

    rng = np.random.default_rng(11)
    for _ in range(50):
        reached = pin.SE3(pin.exp3(rng.normal(size=3)), np.zeros(3))
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        sides = []
        for gap in (5e-7 * 0.999, 5e-7 * 1.001):
            target = reached.rotation @ pin.exp3((np.pi - gap) * axis).T
            errors = np.empty(6)
            *_, exact = geometry.pose_errors(reached.homogeneous, np.zeros(3), target, errors[:3], errors[3:],
                                             None)
            sides.append((exact, errors[3:] if exact else geometry.rotation_error(reached.rotation, target)))
        assert [exact for exact, _ in sides] == [False, True]
        np.testing.assert_allclose(sides[0][1], sides[1][1], rtol=0, atol=1e-9 + 1e-15 / 5e-7)


@COMPILED_TWIN
@pytest.mark.numerics
def test_pose_errors_in_a_base_frame():
    """With a base's inverse placement B^-1 (a chain whose base is not the model's root), the twins give the
    same bits, and the errors are those of Pinocchio's B^-1 W (W: the tip in the root frame) to rounding."""
    from wbik import geometry

    rng = np.random.default_rng(5)
    for _ in range(300):
        base = pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-1.0, 1.0, 3))
        world = pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-2.0, 2.0, 3))
        in_base = base.inverse() * world
        target = in_base * pin.exp6(pin.Motion(10.0 ** rng.uniform(-12, -2) * rng.normal(size=6)))
        outputs = []
        for twin in (geometry._python_pose_errors, geometry._compiled_pose_errors):
            errors = np.empty(8)
            *norms, exact = twin(world.homogeneous, target.translation, target.rotation, errors[:3],
                                 errors[3:6], base.inverse().homogeneous)
            errors[6:] = norms
            outputs.append((exact, errors.tobytes()))
        assert outputs[0] == outputs[1] and outputs[0][0]
        errors = np.frombuffer(outputs[0][1])
        np.testing.assert_allclose(errors[:3], in_base.translation - target.translation, rtol=0, atol=1e-14)
        np.testing.assert_allclose(errors[3:6], geometry.rotation_error(in_base.rotation, target.rotation),
                                   rtol=0, atol=1e-14)


def test_the_check_of_a_chain_with_a_moved_base_agrees_with_its_general_path(rng):
    """The shared check's fast path (the tip in the root frame, the base's inverse applied in the errors'
    kernel) and its general path (the base-frame FK a method hands over) give the same verdicts and errors
    to rounding on the Bioloid's leg, whose base frame is not the model's root."""
    import wbik
    from wbik.solvers.check import evaluate
    from wbik.solvers.result import Candidate, Tolerances

    chain = wbik.load("bioloid").chain("right_leg")
    assert chain.base_inverse_matrix is not None
    for q in chain.random(rng, 50):
        target = wbik.as_target(chain.fk(chain.random(rng)) if rng.random() < 0.5 else chain.fk(q))
        fast = evaluate(chain, target, Candidate(q.copy()), Tolerances(), 0.0, "test")
        general = evaluate(chain, target, Candidate(q.copy()), Tolerances(), 0.0, "test",
                           reached=chain.fk(q).homogeneous)
        assert fast.success == general.success and np.array_equal(fast.q, general.q)
        np.testing.assert_allclose(fast.position_error_xyz, general.position_error_xyz, rtol=0, atol=1e-15)
        np.testing.assert_allclose(fast.rotation_error_xyz, general.rotation_error_xyz, rtol=0, atol=1e-13)


@COMPILED_TWIN
def test_check_fast_paths_twins_agree():
    """inside_limits and plain_finite, the fast-path tests of the shared check and of the start joints:
    both twins give the same verdict on joints inside, on and outside the limits, non-finite ones and
    arrays of another shape or type (those take the general path, which decides)."""
    from wbik import robot
    from wbik.solvers import check

    lower, upper = np.array([-1.0, -2.0, 0.0]), np.array([1.0, 2.0, 0.5])
    inputs = [np.array([0.0, 0.0, 0.25]), lower.copy(), upper.copy(), np.array([1.0 + 1e-16, 0.0, 0.1]),
              np.array([0.0, -2.0000001, 0.1]), np.array([np.nan, 0.0, 0.1]), np.array([0.0, np.inf, 0.1]),
              np.zeros(4), np.zeros((1, 3)), np.zeros(3, dtype=np.float32), [0.0, 0.0, 0.1], None,
              np.array([0.0, 1.0, 0.2, 5.0])[:3], np.arange(6.0)[::2] * 0.1,
              array.array("d", [0.0, 0.0, 0.1]), memoryview(np.array([0.0, 0.0, 0.1])),
              np.ma.masked_array([0.0, 0.0, 0.1]),
              np.array([1e200, 0.0, 0.1])]
    for q in inputs:
        verdicts = {check._python_inside_limits(q, lower, upper), check.inside_limits(q, lower, upper)}
        assert len(verdicts) == 1, q
        finite = {robot._python_plain_finite(q, 3), robot.plain_finite(q, 3)}
        assert len(finite) == 1, q
    for other in inputs[-4:-1]:  # other buffers and subclasses take the general path, which converts them
        assert not check.inside_limits(other, lower, upper) and not robot.plain_finite(other, 3)
    assert robot.plain_finite(np.array([1e200, 0.0, 0.1]), 3)  # finite, though its square is not
    assert check.inside_limits(np.array([0.0, 0.0, 0.25]), lower, upper)
    assert not check.inside_limits(np.array([0.0, -2.0000001, 0.1]), lower, upper)
    assert robot.plain_finite(np.arange(6.0)[::2], 3)
    assert not robot.plain_finite(np.array([0.0, np.nan, 0.0]), 3)


def test_solve_takes_start_joints_of_any_array_kind():
    """Start joints given as a list, an array.array, a memoryview or an ndarray subclass are converted by
    the general path (the fast paths take numpy arrays only), and give the answer of a plain array."""
    import wbik

    solver = wbik.solver("dls", "ur5", chain="arm")
    chain = solver.chain
    target = chain.fk(chain.mid_range + 0.1)
    plain = solver.solve(target, chain.nominal.copy())
    for start in (chain.nominal.tolist(), array.array("d", chain.nominal), memoryview(chain.nominal.copy()),
                  np.ma.masked_array(chain.nominal.copy())):
        answer = solver.solve(target, start)
        assert type(answer.q) is np.ndarray and np.array_equal(answer.q, plain.q), type(start)


@COMPILED_TWIN
def test_pose_errors_refuses_wrong_buffers():
    from wbik import geometry

    pose = random_pose(np.random.default_rng(3))
    three = np.empty(3)
    with pytest.raises(TypeError, match="position"):
        geometry._compiled_pose_errors(pose, np.zeros(4), None, three, three.copy(), None)
    with pytest.raises(TypeError, match="rotation"):
        geometry._compiled_pose_errors(pose, np.zeros(3), np.eye(4), three, three.copy(), None)
    with pytest.raises(TypeError, match="position_error"):
        geometry._compiled_pose_errors(pose, np.zeros(3), None, np.empty(3, dtype=np.float32), three, None)
    with pytest.raises(TypeError, match="rotation_error: expected a writable C-contiguous array"):
        geometry._compiled_pose_errors(pose, np.zeros(3), None, three, np.empty(6)[::2], None)
    read_only = np.empty(3)
    read_only.flags.writeable = False
    with pytest.raises(TypeError, match="position_error: expected a writable C-contiguous array"):
        geometry._compiled_pose_errors(pose, np.zeros(3), None, read_only, three, None)
