"""A robot's typed facts: ``soles``, ``closed_forms`` and ``facts`` instead of an untyped dict.

A URDF loaded by path gets the same facts through ``load(path, soles=..., closed_forms=..., facts=...)``;
readers that need one robot's facts get a typed error on any other robot.
"""

from __future__ import annotations

import pickle
from dataclasses import dataclass

import numpy as np
import pytest

import wbik
from wbik.errors import InvalidOptionError, RobotDescriptionError, SoleError
from wbik.qp.humanoid import support_polygon
from wbik.robot_packages.arm3r.closed_form import arm3r_position
from wbik.robot_packages.arm3r.model import URDF_PATH as ARM3R_URDF
from wbik.robot_packages.arm3r.model import Arm3RFacts, dh_table
from wbik.robot_packages.bioloid.model import URDF_PATH as BIOLOID_URDF
from wbik.robot_packages.bioloid.model import BioloidFacts

HALF = np.array([0.05, 0.03])  # half the 100 x 60 mm sole rectangle, written here by hand
CORNERS = [[0.05, 0.03, 0.0], [-0.05, 0.03, 0.0], [-0.05, -0.03, 0.0], [0.05, -0.03, 0.0]]
ARM3R_FORM = {("default", "position"): arm3r_position}


def test_urdf_humanoid_loaded_with_soles_gets_a_support_polygon():
    robot = wbik.load(BIOLOID_URDF, floating_base=True,
                      soles={"r_sole": CORNERS, "l_sole": CORNERS})
    q = robot.nominal  # neutral: base at the origin, every joint 0, both soles level
    centres = {sole: robot.frame_placement(q, sole) for sole in ("r_sole", "l_sole")}
    for placement in centres.values():
        np.testing.assert_allclose(placement.rotation, np.eye(3), atol=1e-12)
    r, left = centres["r_sole"].translation[:2], centres["l_sole"].translation[:2]
    assert left[1] > r[1]  # y points left
    polygon = support_polygon(robot, q, ["r_sole", "l_sole"])
    # by hand: two side-by-side rectangles make one rectangle from the right sole's outer edge to the left's
    low, high = np.minimum(r, left) - HALF, np.maximum(r, left) + HALF
    assert len(polygon.vertices) == 4
    np.testing.assert_allclose(polygon.vertices.min(axis=0), low, atol=1e-12)
    np.testing.assert_allclose(polygon.vertices.max(axis=0), high, atol=1e-12)
    one_foot = support_polygon(robot, q, ["l_sole"])
    np.testing.assert_allclose(one_foot.vertices.max(axis=0), left + HALF, atol=1e-12)
    assert one_foot.margin_of(left) == pytest.approx(HALF[1])
    with pytest.raises(RobotDescriptionError, match="robot.soles"):
        support_polygon(wbik.load(BIOLOID_URDF, floating_base=True), q, ["r_sole"])


def test_urdf_soles_are_read_only_and_checked():
    robot = wbik.load(BIOLOID_URDF, floating_base=True, soles={"r_sole": CORNERS})
    with pytest.raises(ValueError, match="read-only"):
        robot.soles["r_sole"][0, 0] = 1.0
    for soles, words in (({"r_sol": CORNERS}, ("'r_sol'", "not a frame", "did you mean 'r_sole'")),
                         ({"r_sole": []}, ("'r_sole'", "k >= 1")),
                         ({"r_sole": [[0.0, 0.0]]}, ("'r_sole'", "(k, 3)")),
                         ({"r_sole": [[0.0, 0.0, np.nan]] * 4}, ("finite",)),
                         ({"r_sole": "square"}, ("'r_sole'", "(k, 3)")),
                         ([CORNERS], ("soles must map",))):
        with pytest.raises(RobotDescriptionError) as info:
            wbik.load(BIOLOID_URDF, floating_base=True, soles=soles)
        for word in words:
            assert word in str(info.value)
        if isinstance(soles, dict):  # the sole is named on the typed error, also after pickling
            assert isinstance(info.value, SoleError) and info.value.sole == next(iter(soles))
            copy = pickle.loads(pickle.dumps(info.value))
            assert (type(copy), str(copy), copy.sole) == (SoleError, str(info.value), info.value.sole)


def test_soles_may_be_points_and_edges():
    """A point foot ([x, y, z] or [[x, y, z]]) and an edge (2 points) are soles like a rectangle."""
    robot = wbik.load(BIOLOID_URDF, floating_base=True,
                      soles={"r_sole": [0.01, 0.0, 0.0], "l_sole": CORNERS[:2]})
    assert robot.soles["r_sole"].shape == (1, 3) and robot.soles["l_sole"].shape == (2, 3)
    np.testing.assert_array_equal(robot.soles["r_sole"], [[0.01, 0.0, 0.0]])


def test_urdf_closed_form_needs_its_facts():
    target = np.array([1.0, 2.0, 4.0])
    bare = wbik.load(ARM3R_URDF, closed_forms=ARM3R_FORM)
    with pytest.raises(RobotDescriptionError) as info:
        wbik.solver("analytic", bare).solve(target, q0=np.full(3, 1.5))
    assert "Arm3RFacts" in str(info.value) and "arm3r closed form" in str(info.value)
    lengths = (3.0, 2.0, 2.0)
    robot = wbik.load(ARM3R_URDF, closed_forms=ARM3R_FORM, facts=Arm3RFacts(lengths, dh_table()))
    result = wbik.solver("analytic", robot).solve(target, q0=np.full(3, 1.5))
    assert result.success
    # by hand: standard DH with a = (0, l2, l3), alpha = (pi/2, 0, 0), d = (l1, 0, 0)
    q1, q2, q3 = result.q
    reach = lengths[1] * np.cos(q2) + lengths[2] * np.cos(q2 + q3)
    end = [reach * np.cos(q1), reach * np.sin(q1),
           lengths[0] + lengths[1] * np.sin(q2) + lengths[2] * np.sin(q2 + q3)]
    np.testing.assert_allclose(end, target, atol=1e-9)


def test_closed_forms_and_facts_are_checked():
    path = ARM3R_URDF
    for forms, words in (({("arm", "position"): arm3r_position}, ("'arm'", "chain of ['default']")),
                         ({"default": arm3r_position}, ("(chain, target kind)",)),
                         ({("default", "position"): "module:Class"}, ("class or a factory", "module:Class")),
                         ([("default", "position")], ("closed_forms must map",))):
        with pytest.raises(RobotDescriptionError) as info:
            wbik.load(path, closed_forms=forms)
        for word in words:
            assert word in str(info.value)

    @dataclass
    class Mutable:
        length: float

    for facts in ({"lengths": (3, 2, 2)}, Mutable(1.0), Arm3RFacts):
        with pytest.raises(RobotDescriptionError, match="frozen dataclass"):
            wbik.load(path, facts=facts)
    with pytest.raises(InvalidOptionError) as info:  # the untyped dict is gone
        wbik.load(path, info={"lengths": (3, 2, 2)})
    assert "soles" in info.value.accepted and "closed_forms" in info.value.accepted


def test_readers_name_the_facts_they_need():
    ur5 = wbik.load("ur5")
    with pytest.raises(RobotDescriptionError) as info:
        ur5.require_facts(BioloidFacts, "the Bioloid whole-body step")
    assert all(word in str(info.value) for word in ("BioloidFacts", "UR5Facts", "'ur5'", "whole-body step"))
    bioloid = wbik.load("bioloid", tool_length=0.07)
    assert bioloid.require_facts(BioloidFacts, "test") is bioloid.facts
    assert bioloid.facts.arm_lengths[4] == pytest.approx(0.0745 + 0.07)  # bioloid.md: L4 = 0.0745 + tool
    assert bioloid.facts.standing_pitch == pytest.approx(np.radians(20.0))
    with pytest.raises(AttributeError):
        bioloid.facts.tool_length = 0.1  # frozen
    assert not hasattr(bioloid, "info")
