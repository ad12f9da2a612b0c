"""Per-axis errors and the angle convention, checked against Pinocchio and hand-built rotations."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbik.geometry import batch_exp3 as exp3
from wbik.solvers.base import IKResult
from wbik.study.metrics import THESIS_ANGLE_NAMES, axis_errors, euler_zyx, wrap_angle


def _rz(a):
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _ry(a):
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _rx(a):
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def test_euler_angles_invert_rz_ry_rx_and_match_pinocchio():
    rng = np.random.default_rng(4)
    for _ in range(50):
        alpha, gamma = rng.uniform(-np.pi, np.pi, 2)
        beta = rng.uniform(-1.5, 1.5)
        rotation = _rz(gamma) @ _ry(beta) @ _rx(alpha)
        assert np.allclose(euler_zyx(rotation), [alpha, beta, gamma], atol=1e-12)
        assert np.allclose(euler_zyx(rotation), pin.rpy.matrixToRpy(rotation), atol=1e-12)


def test_exp3_matches_pinocchio_including_tiny_angles():
    rng = np.random.default_rng(5)
    vectors = np.vstack([rng.normal(size=(20, 3)), 1e-10 * rng.normal(size=(5, 3)), np.zeros((1, 3))])
    for vector, matrix in zip(vectors, exp3(vectors), strict=True):
        assert np.allclose(matrix, pin.exp3(vector), atol=1e-14)


def test_wrap_angle():
    assert np.allclose(wrap_angle(np.array([0.0, 3 * np.pi / 2, -3 * np.pi / 2, 2 * np.pi + 0.1])),
                       [0.0, -np.pi / 2, np.pi / 2, 0.1])


def _result(position_xyz, rotation_xyz, q=(0.0,)):
    return IKResult(np.array(q), True, "", float(np.linalg.norm(position_xyz)),
                    float(np.linalg.norm(rotation_xyz)), np.array(position_xyz, dtype=float),
                    np.array(rotation_xyz, dtype=float), 1e-3, 1)


def test_axis_errors_of_a_small_rotation_about_the_tool_x_axis_land_on_alpha():
    # target R* = Rz(0.3) Ry(0.2) Rx(0.1); reached R = R* Rx(1e-4): only alpha (thesis 'yaw') changes
    target = _rz(0.3) @ _ry(0.2) @ _rx(0.1)
    columns = axis_errors([_result([1e-7, -2e-7, 0.0], [1e-4, 0.0, 0.0])], target[None], THESIS_ANGLE_NAMES)
    assert np.allclose([columns["err_x"][0], columns["err_y"][0], columns["err_z"][0]], [1e-7, -2e-7, 0])
    assert np.isclose(columns["err_rot_x"][0], 1e-4)
    assert np.isclose(columns["err_alpha"][0], 1e-4, rtol=1e-6)
    assert abs(columns["err_beta"][0]) < 1e-12 and abs(columns["err_gamma"][0]) < 1e-12
    assert columns["err_thesis_yaw"][0] == columns["err_alpha"][0]
    assert columns["err_thesis_roll"][0] == columns["err_gamma"][0]


def test_position_only_answers_have_no_angle_columns_and_missing_joints_give_nan():
    missing = IKResult(None, False, "no solution", np.nan, np.nan, np.full(3, np.nan), np.full(3, np.nan),
                       1e-3, 1)
    columns = axis_errors([_result([0.0, 0.0, 1e-3], [0.0, 0.0, 0.0]), missing], None)
    assert set(columns) == {"err_x", "err_y", "err_z"}
    assert columns["err_z"][0] == 1e-3 and np.isnan(columns["err_z"][1])
    pose_columns = axis_errors([missing], np.eye(3)[None])
    assert np.isnan(pose_columns["err_alpha"][0])
