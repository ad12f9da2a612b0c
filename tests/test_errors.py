"""Every bad input raises a typed wbik error whose message says what to fix."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik


def test_unknown_robot_lists_the_known_ones():
    with pytest.raises(wbik.UnknownRobotError, match="pincher") as info:
        wbik.load("golem4")
    assert "urdf" in str(info.value).lower()


def test_unknown_chain_and_frame():
    robot = wbik.load("ur5")
    with pytest.raises(wbik.UnknownChainError, match="arm"):
        robot.chain("leg")
    with pytest.raises(wbik.UnknownChainError, match="several chains"):
        robot.chain()
    with pytest.raises(wbik.UnknownFrameError, match="tcp"):
        robot.frame_id("tcpp")


def test_unknown_method():
    with pytest.raises(wbik.UnknownMethodError, match="dls"):
        wbik.solver("magic", "pincher")


@pytest.mark.parametrize("target, error", [
    (np.array([np.nan, 0.0, 0.2]), wbik.InvalidTargetError),
    (np.array([np.inf, 0.0, 0.2]), wbik.InvalidTargetError),
    (np.array([0.1, 0.2]), wbik.InvalidTargetError),
    (np.zeros((2, 3)), wbik.InvalidTargetError),
    ("0.1 0.2 0.3", wbik.InvalidTargetError),
    (np.diag([1.0, 1.0, 1.0, 2.0]), wbik.InvalidTargetError),
])
def test_malformed_targets(target, error):
    with pytest.raises(error):
        wbik.solver("dls", "pincher").solve(target)


def test_not_a_rotation():
    solver = wbik.solver("dls", "ur5", chain="arm")
    scaled = np.eye(4)
    scaled[:3, :3] *= 1.1
    with pytest.raises(wbik.InvalidRotationError, match="orthonormal"):
        solver.solve(scaled)
    mirrored = np.eye(4)
    mirrored[2, 2] = -1.0
    with pytest.raises(wbik.InvalidRotationError, match="det"):
        solver.solve(mirrored)
    with pytest.raises(wbik.InvalidRotationError):
        wbik.as_target([0.1, 0.2, 0.3], rotation=np.ones((3, 3)))


def test_bad_start_configuration():
    solver = wbik.solver("dls", "pincher")
    with pytest.raises(wbik.InvalidConfigurationError, match="4 joints"):
        solver.solve([0.1, 0.1, 0.2], q0=[0.0, 0.0])
    with pytest.raises(wbik.InvalidConfigurationError, match="NaN"):
        solver.solve([0.1, 0.1, 0.2], q0=[0.0, np.nan, 0.0, 0.0])


def test_broken_urdf(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(wbik.RobotDescriptionError, match="URDF"):
        wbik.load(broken)
    with pytest.raises(wbik.RobotDescriptionError, match="does not exist"):
        wbik.load(tmp_path / "missing.urdf")


def test_errors_are_catchable_as_builtin_kinds():
    with pytest.raises(KeyError):
        wbik.load("nope")
    with pytest.raises(ValueError):
        wbik.as_target([np.nan, 0, 0])


def test_se3_target_is_accepted():
    chain = wbik.load("ur5").chain("arm")
    target = wbik.as_target(pin.SE3(chain.fk(chain.nominal)))
    assert target.is_pose and target.rotation.shape == (3, 3)


def test_new_errors_keep_the_builtin_kinds():
    from wbik.errors import (
        InvalidBudgetError,
        InvalidOptionError,
        InvalidSettingError,
        InvalidToleranceError,
        UsageError,
    )

    assert issubclass(InvalidOptionError, TypeError) and issubclass(InvalidOptionError, wbik.WbikError)
    for error in (InvalidSettingError, InvalidToleranceError, InvalidBudgetError, UsageError):
        assert issubclass(error, ValueError) and issubclass(error, wbik.WbikError)
    with pytest.raises(TypeError):
        wbik.solver("dls", "pincher", misspelled_option=1)
    with pytest.raises(ValueError):
        wbik.Tolerances(-1, -1)


def test_ragged_and_dict_targets_are_invalid_targets():
    with pytest.raises(wbik.InvalidTargetError, match="equal length"):
        wbik.as_target([[1, 0, 0, 0], [0, 1, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    with pytest.raises(wbik.InvalidTargetError, match="dict"):
        wbik.as_target({"x": 1})
    with pytest.raises(wbik.InvalidTargetError, match="magnitude"):
        wbik.as_target([1e300, 0, 0])


def test_errors_keep_their_message_and_fields_across_processes():
    """A study worker's error reaches the main process by pickle: message and fields survive."""
    import pickle

    from wbik.errors import InvalidOptionError, NoQPSolutionError, UnknownMethodError

    for error in (UnknownMethodError("x", ["dls", "qp"], hint="see wbik methods"),
                  InvalidOptionError("bad option 'y'", option="y", accepted=["a", "b"]),
                  NoQPSolutionError("no solution", backend="daqp", status=-6)):
        copy = pickle.loads(pickle.dumps(error))
        assert type(copy) is type(error) and str(copy) == str(error)
        assert vars(copy) == vars(error)


def test_did_you_mean_names_the_closest_choice_or_nothing():
    from wbik.errors import closest_name, did_you_mean

    assert closest_name("bounded_ml", ["dls", "bounded_lm", "newton"]) == "bounded_lm"
    assert did_you_mean("bounded_ml", ["dls", "bounded_lm"]) == " (did you mean 'bounded_lm'?)"
    assert closest_name("zzzz", ["dls", "kdl"]) is None and did_you_mean("zzzz", ["dls", "kdl"]) == ""
