"""The trajectory object: achieved tip path, tracking error and JointTrajectory-shaped export."""

import csv
import json

import numpy as np
import pytest

import wbik
from wbik.motion import joint_path, make_trajectory, time_scale, waypoint_path


@pytest.fixture(scope="module")
def trajectory():
    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot, timeout_s=0.05)
    path = waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3), (0, -2, 2), (0, -2, 5)], 10)
    return make_trajectory(time_scale(path, "quintic", 1.0, mode="waypoint"))


def test_knots_track_the_line(trajectory):
    assert len(trajectory.times) == 31
    assert trajectory.max_position_error <= 1e-6
    chain = wbik.load("arm3r").chain()
    for q, tip in zip(trajectory.positions, trajectory.tip_positions, strict=True):
        assert np.allclose(chain.fk(q).translation, tip, atol=1e-12)
    # at rest at the start, the end and each waypoint (waypoint mode, minimum-jerk law)
    assert np.allclose(trajectory.velocities[[0, 10, 20, 30]], 0.0, atol=1e-12)


def test_dense_sampling_error_is_small_and_reported():
    robot = wbik.load("arm3r")
    solver = wbik.solver("dls", robot, timeout_s=0.05)
    path = waypoint_path(solver, np.full(3, np.pi / 2), [(2, -3, 3)], samples=40)
    dense = make_trajectory(time_scale(path, "cubic", 1.0), dt=0.01)
    assert dense.times[-1] == pytest.approx(dense.duration)
    # between knots the spline leaves the line a little; the error is measured, not hidden
    assert 1e-9 < dense.max_position_error < 1e-3


def test_json_has_the_joint_trajectory_shape(trajectory, tmp_path):
    data = json.loads(trajectory.write_json(tmp_path / "t.json").read_text())
    assert data["joint_names"] == ["joint1", "joint2", "joint3"]
    assert len(data["points"]) == 31
    stamps = [p["time_from_start"]["sec"] + p["time_from_start"]["nanosec"] * 1e-9 for p in data["points"]]
    assert np.all(np.diff(stamps) > 0) and stamps[-1] == pytest.approx(trajectory.duration, abs=1e-9)
    point = data["points"][12]
    assert set(point) == {"positions", "velocities", "accelerations", "time_from_start"}
    assert point["positions"] == pytest.approx(trajectory.positions[12].tolist())
    assert len(data["wbik"]["tip_positions_m"]) == 31


def test_csv_round_trip(trajectory, tmp_path):
    with trajectory.write_csv(tmp_path / "t.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 31
    assert float(rows[-1]["time_s"]) == pytest.approx(trajectory.duration, abs=1e-9)
    assert float(rows[5]["joint2"]) == pytest.approx(trajectory.positions[5, 1], abs=1e-11)
    assert float(rows[5]["tip_z"]) == pytest.approx(trajectory.tip_positions[5, 2], abs=1e-11)
    assert float(rows[5]["position_error_m"]) <= 1e-6


def test_joint_trajectory_has_no_reference_error(tmp_path):
    chain = wbik.load("pincher").chain()
    result = make_trajectory(time_scale(joint_path(chain, [np.zeros(4), np.full(4, 0.3)], 3), "linear"))
    assert result.max_position_error is None
    with (tmp_path / "j.csv").open("w"):
        pass
    rows = list(csv.DictReader(result.write_csv(tmp_path / "j.csv").open()))
    assert rows[0]["position_error_m"] == ""
