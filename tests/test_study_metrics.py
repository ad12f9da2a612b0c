"""Per-axis errors and Euler-angle conventions, checked against Pinocchio, scipy and hand-built rotations."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from wbik.errors import InvalidSettingError
from wbik.geometry import TAIT_BRYAN_SEQUENCES, tait_bryan_angles
from wbik.geometry import batch_exp3 as exp3
from wbik.geometry import wrap_to_pi as wrap_angle
from wbik.solvers.result import IKResult
from wbik.study.metrics import AngleConvention, axes, axis_errors, axis_label

YAW_PITCH_ROLL = AngleConvention("zyx", (("x", "yaw"), ("y", "pitch"), ("z", "roll")))
"""Names for the study's own angles (alpha about x 'yaw', beta 'pitch', gamma about z 'roll')."""


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
        assert np.allclose(tait_bryan_angles(rotation, "zyx"), [alpha, beta, gamma], atol=1e-12)
        assert np.allclose(tait_bryan_angles(rotation), pin.rpy.matrixToRpy(rotation), atol=1e-12)


_ELEMENTARY = {"x": _rx, "y": _ry, "z": _rz}


@pytest.mark.parametrize("sequence", TAIT_BRYAN_SEQUENCES)
def test_every_tait_bryan_sequence_inverts_its_product_and_matches_scipy(sequence):
    """R = R_i(a_i) R_j(a_j) R_k(a_k) built by hand; scipy's intrinsic "IJK" gives (a_i, a_j, a_k)."""
    rng = np.random.default_rng(6)
    for _ in range(40):
        angles = dict(zip("xyz", rng.uniform(-np.pi, np.pi, 3), strict=True))
        angles[sequence[1]] = rng.uniform(-1.5, 1.5)  # the middle angle away from gimbal lock
        rotation = np.linalg.multi_dot([_ELEMENTARY[axis](angles[axis]) for axis in sequence])
        ours = tait_bryan_angles(rotation, sequence)
        assert np.allclose(ours, [angles["x"], angles["y"], angles["z"]], atol=1e-12)
        theirs = Rotation.from_matrix(rotation).as_euler(sequence.upper())
        assert np.allclose([ours["xyz".index(axis)] for axis in sequence], theirs, atol=1e-12)
    batch = rng.normal(size=(4, 5, 3))
    rotations = Rotation.from_rotvec(batch.reshape(-1, 3)).as_matrix().reshape(4, 5, 3, 3)
    assert tait_bryan_angles(rotations, sequence).shape == (4, 5, 3)


def test_an_unknown_sequence_is_a_typed_error():
    with pytest.raises(InvalidSettingError, match="zyz"):
        tait_bryan_angles(np.eye(3), "zyz")


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
    # target R* = Rz(0.3) Ry(0.2) Rx(0.1); reached R = R* Rx(1e-4): only alpha (named 'yaw') changes
    target = _rz(0.3) @ _ry(0.2) @ _rx(0.1)
    columns = axis_errors([_result([1e-7, -2e-7, 0.0], [1e-4, 0.0, 0.0])], target[None], YAW_PITCH_ROLL)
    assert np.allclose([columns["err_x"][0], columns["err_y"][0], columns["err_z"][0]], [1e-7, -2e-7, 0])
    assert np.isclose(columns["err_rot_x"][0], 1e-4)
    assert np.isclose(columns["err_alpha"][0], 1e-4, rtol=1e-6)
    assert abs(columns["err_beta"][0]) < 1e-12 and abs(columns["err_gamma"][0]) < 1e-12
    assert columns["err_yaw"][0] == columns["err_alpha"][0]
    assert columns["err_roll"][0] == columns["err_gamma"][0]
    assert axes("pose", YAW_PITCH_ROLL)[-4:] == ["gamma", "yaw", "pitch", "roll"]
    assert axis_label("yaw", YAW_PITCH_ROLL) == "yaw (= alpha, rad)"


def test_a_reference_sequence_of_its_own_gets_its_own_angles():
    # sequence xyz: R* = Rx(0.9) Ry(0.7) Rz(0.3); reached R = R* Rz(1e-4): only the angle about z changes
    convention = AngleConvention("xyz", (("x", "phi"), ("z", "psi")))
    target = _rx(0.9) @ _ry(0.7) @ _rz(0.3)
    columns = axis_errors([_result([0.0, 0.0, 0.0], [0.0, 0.0, 1e-4])], target[None], convention)
    assert np.isclose(columns["err_psi"][0], 1e-4, rtol=1e-6) and abs(columns["err_phi"][0]) < 1e-12
    assert "err_theta" not in columns
    assert abs(columns["err_alpha"][0]) > 1e-6  # the study's own zyx angles split the same rotation
    assert axes("pose", convention)[-2:] == ["phi", "psi"]
    assert axis_label("psi", convention) == "psi (about z in R = Rx(phi) Ry(.) Rz(psi), rad)"


def test_position_only_answers_have_no_angle_columns_and_missing_joints_give_nan():
    missing = IKResult(None, False, "no solution", np.nan, np.nan, np.full(3, np.nan), np.full(3, np.nan),
                       1e-3, 1)
    columns = axis_errors([_result([0.0, 0.0, 1e-3], [0.0, 0.0, 0.0]), missing], None)
    assert set(columns) == {"err_x", "err_y", "err_z"}
    assert columns["err_z"][0] == 1e-3 and np.isnan(columns["err_z"][1])
    pose_columns = axis_errors([missing], np.eye(3)[None])
    assert np.isnan(pose_columns["err_alpha"][0])
