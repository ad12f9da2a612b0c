"""Pincher and arm3r models against the seeds' numbers."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin

import wbik

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from export_urdf import exported  # noqa: E402


def test_pincher_fk_matches_seed_example():
    # pincher.md: q = [15, 30, 45, 60] deg gives this R and p (mm).
    chain = wbik.load("pincher").chain("arm")
    pose = chain.fk(np.radians([15, 30, 45, 60]))
    expected_r = np.array([[0.6830, 0.2588, 0.6830], [0.1830, -0.9659, 0.1830], [0.7071, 0.0, -0.7071]])
    assert np.allclose(pose.rotation, expected_r, atol=1e-4)
    assert np.allclose(pose.translation * 1000, [213.5636, 57.2242, 187.9335], atol=1e-4)


def test_pincher_zyz_euler_of_seed_example():
    # pincher.md gives ZYZ Euler angles [15, 135, -180] deg for the same q.
    rotation = wbik.load("pincher").chain("arm").fk(np.radians([15, 30, 45, 60])).rotation
    phi = math.atan2(rotation[1, 2], rotation[0, 2])
    theta = math.atan2(math.hypot(rotation[0, 2], rotation[1, 2]), rotation[2, 2])
    psi = math.atan2(rotation[2, 1], -rotation[2, 0])
    assert np.allclose(np.degrees([phi, theta]), [15, 135], atol=1e-4)
    assert abs(abs(math.degrees(psi)) - 180) < 1e-4


def test_pincher_limits_are_150_degrees():
    chain = wbik.load("pincher").chain("arm")
    assert np.allclose(np.degrees(chain.upper), 150) and np.allclose(np.degrees(chain.lower), -150)


def test_arm3r_start_point_and_closed_form(rng):
    # arm3r.md: theta = (pi/2, pi/2, pi/2) gives (0, -l3, l1 + l2); the closed-form x, y, z hold.
    for lengths in [(3.0, 2.0, 2.0), tuple(rng.uniform(0.5, 3.0, size=3))]:
        l1, l2, l3 = lengths
        chain = wbik.load("arm3r", lengths=lengths).chain("arm")
        assert np.allclose(chain.fk(np.full(3, math.pi / 2)).translation, [0, -l3, l1 + l2], atol=1e-12)
        for q in chain.random(rng, 100):
            c1, s1, c2, s2, c3, s3 = (np.cos(q[0]), np.sin(q[0]), np.cos(q[1]), np.sin(q[1]),
                                      np.cos(q[2]), np.sin(q[2]))
            x = l3 * c1 * c2 * c3 - l3 * c1 * s2 * s3 + l2 * c1 * c2
            y = l3 * s1 * c2 * c3 - l3 * s1 * s2 * s3 + l2 * s1 * c2
            z = l1 + l2 * s2 + l3 * c2 * s3 + l3 * s2 * c3
            assert np.allclose(chain.fk(q).translation, [x, y, z], atol=1e-12)


def test_committed_urdf_files_are_the_dh_tables():
    for path, text in exported().items():
        committed = path.read_text()
        assert committed == text, f"{path} is stale: run scripts/export_urdf.py"
        model = pin.buildModelFromXML(committed)
        assert model.nq in (3, 4)


def test_ur5_tcp_frame_is_the_tool_tip():
    robot = wbik.load("ur5")
    q = np.array([0.3, -1.2, 1.0, -0.5, 1.1, 0.2])
    ee = robot.chain("ee").fk(q)
    tcp = robot.chain("arm").fk(q)
    # tcp = ee_link moved 0.13 m along its x axis (the flange normal), z axis along that direction.
    assert np.allclose(tcp.translation, ee.translation + 0.13 * ee.rotation[:, 0], atol=1e-12)
    assert np.allclose(tcp.rotation[:, 2], ee.rotation[:, 0], atol=1e-12)
    assert robot.facts.tool_diameter == 0.005


def test_builtin_list_and_descriptions():
    names = wbik.robots()
    assert {"golem3", "pincher", "bioloid", "arm3r", "ur5", "panda"} <= set(names)
    assert all(names.values())
