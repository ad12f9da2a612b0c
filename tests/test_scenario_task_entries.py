"""Task entries (wbik.qp.task_entries): the mapping form of a QP task, targets resolved at q.

Targets are checked against the robot's own FK at q and hand-composed placements; bad entries raise
TaskEntryError (an InvalidSettingError) naming what is wrong, in the schema's words.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.errors import InvalidSettingError
from wbik.qp import tasks as T
from wbik.qp.task_entries import TaskEntryError, build_task


@pytest.fixture(scope="module")
def golem():
    return wbik.load("golem3")


@pytest.fixture(scope="module")
def q(golem):
    rng = np.random.default_rng(3)
    return pin.randomConfiguration(golem.model, *_limits(golem, rng))


def _limits(robot, rng):
    lower = np.where(np.isfinite(robot.model.lowerPositionLimit), robot.model.lowerPositionLimit, -1.0)
    upper = np.where(np.isfinite(robot.model.upperPositionLimit), robot.model.upperPositionLimit, 1.0)
    return lower, upper


def test_frame_targets_absolute_offset_and_kept(golem, q):
    start = golem.frame_placement(q, "r_eef")
    rotation = pin.rpy.rpyToMatrix(0.1, -0.2, 0.3)
    absolute = build_task(golem, q, {"type": "frame", "frame": "r_eef", "target": [0.4, -0.2, 1.1],
                                     "rpy": [0.1, -0.2, 0.3], "orientation_weight": 0.5})
    assert isinstance(absolute, T.FrameTask)
    np.testing.assert_allclose(absolute.target.translation, [0.4, -0.2, 1.1])
    np.testing.assert_allclose(absolute.target.rotation, rotation, atol=1e-15)
    shifted = build_task(golem, q, {"type": "position", "frame": "r_eef", "offset": [0.0, 0.05, -0.1],
                                    "axes": "xz"})
    assert isinstance(shifted, T.PositionTask)
    np.testing.assert_allclose(shifted.target, start.translation + [0.0, 0.05, -0.1], atol=1e-15)
    kept = build_task(golem, q, {"type": "orientation", "frame": "r_eef", "keep": True, "weight": 0.1,
                                 "goal": False})
    np.testing.assert_allclose(kept.target, start.rotation, atol=1e-15)
    assert kept.goal is False and np.all(kept.weight == 0.1)


def test_relative_com_posture_and_regularization(golem, q):
    right, left = golem.frame_placement(q, "r_eef"), golem.frame_placement(q, "l_eef")
    relative = build_task(golem, q, {"type": "relative", "frame": "l_eef", "reference": "r_eef",
                                     "offset": [0.0, 0.1, 0.0]})
    in_right = right.inverse() * left  # the left gripper seen from the right one
    np.testing.assert_allclose(relative.target.translation, in_right.translation + [0.0, 0.1, 0.0],
                               atol=1e-12)
    np.testing.assert_allclose(relative.target.rotation, in_right.rotation, atol=1e-12)
    com = build_task(golem, q, {"type": "com", "over": "r_eef", "axes": "xy"})
    wanted = np.array([right.translation[0], right.translation[1], golem.center_of_mass(q)[2]])
    np.testing.assert_allclose(com.target, wanted, atol=1e-12)
    posture = build_task(golem, q, {"type": "posture", "reference": "start"})
    assert isinstance(posture, T.PostureTask)
    regularization = build_task(golem, q, {"type": "regularization"})
    assert isinstance(regularization, T.RegularizationTask) and np.all(regularization.weight == 1e-6)


@pytest.mark.parametrize("entry, words", [
    ({"frame": "r_eef"}, ["task entry: ", "needs a 'type'", "com, frame"]),
    ({"type": "teleport", "frame": "r_eef"}, ["type: type 'teleport' is not allowed", "com, frame"]),
    ({"type": "position", "offset": [0, 0, 1]}, ["missing the required key 'frame'"]),
    ({"type": "relative", "frame": "l_eef"}, ["'reference'"]),
    ({"type": "position", "frame": "nose", "offset": [0, 0, 0.1]}, ["nose"]),
    ({"type": "frame", "frame": "r_eef", "target": [0, 0]},
     ["task entry: target must be a list of 3 finite numbers, got [0, 0] (list)"]),
    ({"type": "com", "offset": [0, float("nan"), 0]},
     ["offset[1] must be a finite number", "got nan (float)"]),
    ({"type": "com", "ovr": "r_eef"}, ["task entry: ovr: unknown field(s) ['ovr'] (did you mean 'over'?)"]),
])
def test_bad_entries_raise_task_entry_errors(golem, q, entry, words):
    with pytest.raises(TaskEntryError) as info:
        build_task(golem, q, entry)
    assert isinstance(info.value, InvalidSettingError)
    for word in words:
        assert word in str(info.value)
