"""Hostile-but-fair input: every bad input raises a typed WbikError that says what to fix.

Tried against every registered method on every chain of every built-in robot (each robot loaded
once), plus hostile URDF files, robot parameters, solver options, tolerances, budgets, study files
and the CLI's exit codes (0 done, 1 not solved, 2 bad input, 3 internal error), and a randomized fuzz of
20,000 malformed inputs at the end.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import wbik
from wbik.errors import (
    InvalidBudgetError,
    InvalidConfigurationError,
    InvalidOptionError,
    InvalidTargetError,
    InvalidToleranceError,
    RobotDescriptionError,
    UnsupportedError,
    WbikError,
)
from wbik.options import TIMEOUT_S
from wbik.solvers.method_registry import methods, solver_options
from wbik.solvers.result import Tolerances

BARE = (ValueError, TypeError, KeyError, IndexError, AttributeError, RuntimeError)
ROBOTS = {name: wbik.load(name) for name in wbik.robots()}
CHAINS = [(robot, chain) for robot, model in ROBOTS.items() for chain in model.chains]
METHODS = list(methods())
WBIK = Path(sys.executable).parent / "wbik"
_SOLVERS: dict[tuple[str, str, str], wbik.Solver] = {}


def solver_for(method: str, robot: str, chain: str) -> wbik.Solver:
    key = (method, robot, chain)
    if key not in _SOLVERS:
        _SOLVERS[key] = wbik.solver(method, ROBOTS[robot], chain=chain)
    return _SOLVERS[key]


def assert_typed(error: BaseException, *words: str) -> None:
    """A WbikError subclass (never a bare builtin) whose message is a sentence naming ``words``."""
    assert isinstance(error, WbikError), f"{type(error).__name__}: {error}"
    assert type(error) not in BARE
    message = str(error)
    assert len(message) > 25, message
    for word in words:
        assert word.lower() in message.lower(), (word, message)


class Ragged:
    """An object numpy cannot turn into numbers."""


BAD_TARGETS = [
    ("ragged 4x4", [[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "equal length"),
    ("ragged rows", [[0.1, 0.2], [0.3]], "equal length"),
    ("dict", {"x": 0.1, "y": 0.2, "z": 0.3}, "dict"),
    ("string", "0.1 0.2 0.3", "str"),
    ("bytes", b"0.1", "bytes"),
    ("None", None, "None"),
    ("complex scalar", 1 + 2j, "complex"),
    ("complex vector", np.array([0.1 + 1j, 0.2, 0.3]), "complex"),
    ("bool", True, "boolean"),
    ("bool vector", [True, False, True], "boolean"),
    ("object array", np.array([0.1, 0.2, 0.3], dtype=object), "objects"),
    ("object", Ragged(), "objects"),
    ("string array", np.array(["a", "b", "c"]), "strings"),
    ("1e300", [1e300, 0.0, 0.0], "magnitude"),
    ("nan", [np.nan, 0.0, 0.2], "NaN"),
    ("inf", [0.0, -np.inf, 0.2], "inf"),
    ("2-vector", [0.1, 0.2], "shape"),
    ("6-vector", np.zeros(6), "shape"),
    ("empty", [], "shape"),
    ("3x3", np.eye(3), "shape"),
    ("4x4 bad last row", np.diag([1.0, 1.0, 1.0, 2.0]), "last row"),
    ("4x4 not a rotation", np.diag([2.0, 1.0, 1.0, 1.0]), "rotation"),
    ("4x4 nan", np.full((4, 4), np.nan), "NaN"),
    ("4x4 huge translation", np.block([[np.eye(3), np.full((3, 1), 1e300)], [np.zeros((1, 3)), 1.0]]),
     "magnitude"),
]

BAD_Q0 = [
    ("too short", [0.0], "joints"),
    ("nan", "nan", "NaN"),
    ("string", "abc", "str"),
    ("dict", {"q": 0}, "dict"),
    ("complex", "complex", "complex"),
    ("ragged", [[0.0], [0.0, 0.0]], "equal length"),
    ("bools", "bools", "boolean"),
]


def _q0(chain, spec):
    if spec == "nan":
        q = chain.nominal.copy()
        q[0] = np.nan
        return q
    if spec == "complex":
        return chain.nominal.astype(complex)
    if spec == "bools":
        return np.ones(chain.nq, dtype=bool)
    return spec


@pytest.mark.parametrize("robot, chain", CHAINS, ids=[f"{r}.{c}" for r, c in CHAINS])
@pytest.mark.parametrize("method", METHODS)
def test_bad_targets_and_starts_every_method_and_chain(method, robot, chain):
    try:
        solver = solver_for(method, robot, chain)
    except UnsupportedError as refusal:  # a method that does not apply to this chain says so, typed
        assert_typed(refusal, chain)
        return
    for label, target, word in BAD_TARGETS:
        with pytest.raises(InvalidTargetError) as info:
            solver.solve(target)
        assert_typed(info.value, word)
        with pytest.raises(InvalidTargetError) as info:
            solver.solve_many([target])
        assert_typed(info.value)
        with pytest.raises(InvalidTargetError):
            solver.solve_many(target if label == "ragged rows" else [target, target])
    model = ROBOTS[robot].chain(chain)
    good = model.fk(model.nominal)
    good = good if solver.supports_pose else good.translation
    for label, spec, word in BAD_Q0:
        with pytest.raises(WbikError) as info:
            solver.solve(good, q0=_q0(model, spec))
        if isinstance(info.value, UnsupportedError):  # e.g. no closed form for this chain: fine, typed
            return
        assert isinstance(info.value, InvalidConfigurationError), (label, info.value)
        assert_typed(info.value, word)
    with pytest.raises(WbikError) as info:
        solver.solve_many([good, good], q0s=np.zeros((3, model.nq)))
    # the method may refuse the chain first (e.g. no closed form for it): typed too, as above
    assert isinstance(info.value, InvalidConfigurationError | UnsupportedError), info.value


@pytest.mark.parametrize("method", METHODS)
def test_options_budgets_and_tolerances_every_method(method):
    robot = ROBOTS["ur5"]
    with pytest.raises(InvalidOptionError) as info:
        wbik.solver(method, robot, chain="arm", misspelled_option=1)
    assert_typed(info.value, "misspelled_option", "timeout_s")
    assert isinstance(info.value, TypeError)  # old ``except TypeError`` code still works
    assert set(info.value.accepted) == solver_options(method)
    for bad in (0, -1, np.nan, np.inf, "abc", True, [1]):
        with pytest.raises(InvalidBudgetError) as info:
            wbik.solver(method, robot, chain="arm", timeout_s=bad)
        assert_typed(info.value, "timeout_s", "> 0")
        assert isinstance(info.value, ValueError)
    with pytest.raises(WbikError) as info:
        wbik.solver(method, robot, chain=["arm"])
    assert_typed(info.value, "chain")
    with pytest.raises(WbikError) as info:
        wbik.solver(method, 42, chain="arm")
    assert_typed(info.value, "robot")


def test_unknown_method_names():
    for bad in ("magic", "", ["dls"], None, 3):
        with pytest.raises(WbikError) as info:
            wbik.solver(bad, ROBOTS["pincher"])
        assert_typed(info.value, "dls")


@pytest.mark.parametrize("values", [(-1, -1), (0, 1e-6), (1e-6, np.nan), (np.inf, 1e-6), ("a", 1e-6),
                                    (None, 1e-6), (True, 1e-6)])
def test_bad_tolerances(values):
    with pytest.raises(InvalidToleranceError) as info:
        Tolerances(*values)
    assert_typed(info.value, "Tolerances: tolerances.", "must be a finite number > 0")
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("value", [0, -1, np.nan, np.inf, -np.inf, "abc", None, True, [0.1], 1 + 1j])
def test_check_budget(value):
    with pytest.raises(InvalidBudgetError) as info:
        TIMEOUT_S.checked(value, "timeout_s", "test")
    assert_typed(info.value, "test: timeout_s must be", "> 0")
    assert TIMEOUT_S.checked(0.25, "timeout_s", "test") == 0.25


# -- robots ---------------------------------------------------------------------------------------
def test_bad_robot_parameters(tmp_path):
    with pytest.raises(InvalidOptionError) as info:
        wbik.load("ur5", foo=1)
    assert_typed(info.value, "foo")
    with pytest.raises(InvalidOptionError) as info:
        wbik.load("arm3r", length=[1, 2, 3])
    assert_typed(info.value, "lengths")
    for bad in ("abc", [1, 2], [1, 2, np.nan], [1, -2, 3], 5, None, {"a": 1}):
        with pytest.raises(RobotDescriptionError) as info:
            wbik.load("arm3r", lengths=bad)
        assert_typed(info.value, "arm3r")
    for bad in ({"tool_length": "x"}, {"tool_length": -1}, {"pitch": np.nan}, {"pitch": "up"}):
        with pytest.raises(RobotDescriptionError) as info:
            wbik.load("bioloid", **bad)
        assert_typed(info.value, "bioloid")
    for bad in (None, 42, ["ur5"]):
        with pytest.raises(WbikError) as info:
            wbik.load(bad)
        assert_typed(info.value, "urdf")


def test_bad_urdf_paths(tmp_path):
    binary = tmp_path / "binary.urdf"
    binary.write_bytes(b"\xff\xfe\x00<robot>\x80\x81\x00")
    with pytest.raises(RobotDescriptionError) as info:
        wbik.load(binary)
    assert_typed(info.value, "UTF-8", "binary.urdf")
    with pytest.raises(RobotDescriptionError) as info:
        wbik.load(tmp_path / "missing.urdf")
    assert_typed(info.value, "does not exist")
    folder = tmp_path / "folder.urdf"
    folder.mkdir()
    for path in (folder, tmp_path):
        with pytest.raises(RobotDescriptionError) as info:
            wbik.load(path)
        assert_typed(info.value, "directory")
    garbage = tmp_path / "garbage.urdf"
    garbage.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(RobotDescriptionError) as info:
        wbik.load(garbage)
    assert_typed(info.value, "URDF")


def _urdf(joint: str, extra: str = "") -> str:
    return ('<?xml version="1.0"?><robot name="hostile"><link name="base"/><link name="l1"/>'
            f'<link name="l2"/><link name="tip"/>{joint}'
            '<joint name="wrist" type="revolute"><parent link="l1"/><child link="l2"/>'
            '<origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
            '<joint name="tip_fixed" type="fixed"><parent link="l2"/><child link="tip"/>'
            f'<origin xyz="0 0 0.2"/></joint>{extra}</robot>')


def _elbow(kind: str = "revolute", axis: str = "0 0 1", limit: str = 'lower="-1" upper="1"') -> str:
    limit_xml = f'<limit {limit} effort="1" velocity="1"/>' if limit else ""
    return (f'<joint name="elbow" type="{kind}"><parent link="base"/><child link="l1"/>'
            f'<axis xyz="{axis}"/>{limit_xml}</joint>')


@pytest.mark.parametrize("joint, words", [
    (_elbow(limit='lower="1" upper="-1"'), ("'elbow'", "lower limit", "above upper")),
    (_elbow(axis="0 0 0"), ("'elbow'", "zero axis")),
    (_elbow(kind="prismatic", axis="0 0 0"), ("'elbow'", "zero axis")),
], ids=["lower-above-upper", "zero-axis", "zero-axis-prismatic"])
def test_bad_robot_descriptions_are_caught_at_load(tmp_path, joint, words):
    path = tmp_path / "hostile.urdf"
    path.write_text(_urdf(joint))
    with pytest.raises(RobotDescriptionError) as info:
        wbik.load(path)
    assert_typed(info.value, *words)


def test_a_continuous_joint_without_limit_element_loads_as_one_angle_in_one_turn(tmp_path):
    path = tmp_path / "continuous.urdf"
    path.write_text(_urdf(_elbow(kind="continuous", limit="")))
    chain = wbik.load(path, chains=[wbik.ChainSpec("arm", "base", "tip", ("elbow", "wrist"))]).chain("arm")
    assert chain.nq == 2 and chain.continuous.tolist() == [True, False]
    assert chain.lower[0] == -np.pi and chain.upper[0] == np.pi
    # locking it (leaving it out of the chain) still works
    locked = wbik.load(path, chains=[wbik.ChainSpec("wrist", "l1", "tip", ("wrist",))])
    assert locked.chain("wrist").nq == 1


def test_a_sane_hostile_twin_loads_and_solves_inside_its_limits(tmp_path):
    path = tmp_path / "sane.urdf"
    path.write_text(_urdf(_elbow()))
    chain = wbik.load(path).chain()
    result = wbik.solver("dls", chain.robot).solve(chain.fk(np.array([0.5, 0.5])).translation)
    assert result.q is not None and chain.in_limits(result.q)


# -- study files ----------------------------------------------------------------------------------
@pytest.mark.parametrize("body, words", [
    ("robot: arm3r\nmethods: [dls]\nmax_poses: 3\n", ("max_poses", "poses")),
    ("robot: arm3r\nrobot_params: [3, 2, 2]\nmethods: [dls]\n", ("robot_params", "mapping")),
    ("robot: arm3r\nrobot_params: {length: 3}\nmethods: [dls]\n", ("robot_params", "length", "lengths")),
    ("robot: arm3r\nmethods: [dlss]\n", ("dlss", "bounded_lm")),
    ("robot: arm3r\nmethods: [{method: dls, options: {dampin: 1}}]\n", ("dampin", "damping")),
    ("robot: arm3r\nmethods: [{method: dls, options: [1]}]\n", ("options", "mapping")),
    ("robot: golem4\nmethods: [dls]\n", ("golem4", "golem3")),
    ("robot: arm3r\nmethods: [dls]\nposes: many\n", ("poses", "positive integer")),
    ("robot: arm3r\nmethods: [dls]\ntolerances: {position: -1}\n", ("tolerances.position", "positive")),
    ("[1, 2, 3]\n", ("mapping",)),
    ("robot: [unclosed\n", ("not valid",)),
])
def test_bad_study_files(tmp_path, body, words):
    from wbik.study import load_study
    from wbik.study.spec import StudyDefinitionError

    path = tmp_path / "hostile.yaml"
    path.write_text(body)
    with pytest.raises(StudyDefinitionError) as info:
        load_study(path)
    assert_typed(info.value, "hostile.yaml", *words)


@pytest.mark.parametrize("method, words", [
    ("{method: dls, options: {max_iterations: -1}}", ("dls", "max_iterations", ">= 1")),
    ("{method: qp, options: {backend: gurobi}}", ("qp", "gurobi", "not installed", "daqp")),
])
def test_bad_option_values_stop_the_study_before_solving(tmp_path, method, words):
    """A bad-valued option or an uninstalled QP backend is an error in the file, not 'not applicable'."""
    from wbik.study import load_study, run_study
    from wbik.study.spec import StudyDefinitionError

    path = tmp_path / "hostile.yaml"
    path.write_text(f"robot: arm3r\ntarget: position\nposes: 5\nmethods: [analytic, {method}]\n")
    with pytest.raises(StudyDefinitionError) as info:
        run_study(load_study(path), tmp_path / "out", jobs=1, progress=False)
    assert_typed(info.value, "hostile.yaml", *words)
    assert not list((tmp_path / "out").rglob("chunk_*.npz"))  # nothing was solved


def test_binary_study_file(tmp_path):
    from wbik.study import load_study

    path = tmp_path / "binary.yaml"
    path.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(WbikError) as info:
        load_study(path)
    assert_typed(info.value, "binary.yaml", "UTF-8")


# -- the CLI's exit codes -------------------------------------------------------------------------
def wbik_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(WBIK), *args], capture_output=True, text=True, timeout=120, cwd=cwd)


def test_cli_bad_input_exits_2_without_traceback(tmp_path):
    cases = [
        ("solve", "pincher", "--xyz", "nan", "0", "0"),
        ("solve", "pincher", "--xyz", "0.1", "0", "0", "--timeout", "-1"),
        ("solve", "pincher", "--xyz", "0.1", "0", "0", "--method", "magic"),
        ("solve", "pincher", "--xyz", "a", "b", "c"),  # argparse
        ("fk", "pincher", "--q", "1", "2"),
        ("study", "--output", str(Path(__file__))),  # a file where a folder is needed
        ("study", "--report-only", "--output", str(tmp_path)),  # nothing to report on
        ("nosuchcommand",),
    ]
    for args in cases:
        out = wbik_cli(*args)
        assert out.returncode == 2, (args, out.stderr)
        assert "Traceback" not in out.stderr, (args, out.stderr)
        assert "error:" in out.stderr, (args, out.stderr)
    out = wbik_cli("solve", "pincher", "--xyz", "nan", "0", "0")
    assert out.stderr.startswith("wbik: error: ") and "NaN" in out.stderr


def test_cli_unreachable_exits_1_and_debug_shows_the_traceback():
    out = wbik_cli("solve", "pincher", "--xyz", "10", "10", "10")
    assert out.returncode == 1 and "NOT solved" in out.stdout and "Traceback" not in out.stderr
    for args in (("--debug", "solve", "pincher", "--xyz", "nan", "0", "0"),
                 ("solve", "pincher", "--xyz", "nan", "0", "0", "--debug")):
        out = wbik_cli(*args)
        assert out.returncode == 2 and "Traceback" in out.stderr and "wbik: error:" in out.stderr


# -- randomized fuzz ------------------------------------------------------------------------------
def _random_malformed(rng: np.random.Generator):
    """A random input that is usually not a valid target: odd shapes, dtypes, NaN/inf, nesting."""
    kind = rng.integers(9)
    shape = tuple(int(n) for n in rng.integers(0, 6, size=rng.integers(0, 4)))
    scale = 10.0 ** float(rng.integers(-3, 300))
    values = rng.normal(scale=scale, size=shape) if shape else rng.normal()
    array = np.asarray(values, dtype=float)
    if array.size and rng.random() < 0.5:
        flat = array.reshape(-1)
        flat[rng.integers(flat.size, size=rng.integers(1, flat.size + 1))] = rng.choice(
            [np.nan, np.inf, -np.inf, 1e300, -0.0])
    if kind == 0:
        return array
    if kind == 1:
        with np.errstate(over="ignore", invalid="ignore"):
            return array.astype(rng.choice([np.complex128, np.int64, np.float32, object, bool, str]))
    if kind == 2:
        return array.tolist()
    if kind == 3:  # ragged nesting
        return [list(rng.normal(size=rng.integers(0, 5))) for _ in range(rng.integers(1, 5))]
    if kind == 4:
        return [[float(v)] if rng.random() < 0.3 else float(v) for v in rng.normal(size=3)]
    if kind == 5:
        return rng.choice(["0 0 0", "", "nan", None, {"x": 1.0}, b"\x00", 1j, True, object(), ...])
    if kind == 6:  # 4x4 with a random defect
        matrix = np.eye(4)
        matrix[rng.integers(4), rng.integers(4)] = rng.choice([np.nan, 2.0, -1.0, 1e300, 1e-3])
        return matrix
    if kind == 7:  # a Target or SE3 with garbage inside
        return wbik.Target(array, None) if rng.random() < 0.5 else wbik.Target(np.zeros(3), array)
    return tuple(array.reshape(-1).tolist()) + ((1 + 1j,) if rng.random() < 0.5 else ())


def test_fuzz_targets_and_starts():
    """Thousands of random malformed inputs: each is either a valid target or a typed WbikError."""
    rng = np.random.default_rng(20260501)
    solvers = []
    for method in METHODS:
        try:
            solvers.append(solver_for(method, "ur5", "arm"))
        except UnsupportedError:  # e.g. the Golem-III thesis's own solvers: refused, typed
            pass
    assert len(solvers) >= len(METHODS) - 3
    chain = ROBOTS["ur5"].chain("arm")
    accepted = rejected = 0
    for index in range(20000):
        value = _random_malformed(rng)
        try:
            target = wbik.as_target(value)
        except WbikError as exc:
            assert_typed(exc)
            rejected += 1
        except Exception as exc:  # noqa: BLE001 - the point of the test
            pytest.fail(f"as_target({value!r}) raised {type(exc).__name__}: {exc}")
        else:
            accepted += 1
            assert np.all(np.isfinite(target.position))
        try:
            chain.check_q(value)
        except WbikError as exc:
            assert_typed(exc)
        except Exception as exc:  # noqa: BLE001
            pytest.fail(f"check_q({value!r}) raised {type(exc).__name__}: {exc}")
        if index % 20 == 0:  # through the solvers too (a bad target fails before any solving)
            solver = solvers[(index // 20) % len(solvers)]
            try:
                solver.solve(value, q0=_random_malformed(rng) if rng.random() < 0.5 else None)
            except WbikError as exc:
                assert_typed(exc)
            except Exception as exc:  # noqa: BLE001
                pytest.fail(f"{solver.name}.solve({value!r}) raised {type(exc).__name__}: {exc}")
    assert rejected > 10000 and accepted < rejected
