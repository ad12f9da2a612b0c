"""Collision primitives (coal through Pinocchio) and the CollisionAvoidance QP constraint.

Expected values are computed independently: capsule distances by hand geometry, the constraint's
row by central finite differences of the coal distance, the best efforts by the capsule radii.
"""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.collision import CollisionModel, Obstacle, Primitive, box, capsule, robot_collision_model
from wbik.errors import InvalidSettingError, RobotDescriptionError, UnknownFrameError, WbikError
from wbik.qp import CollisionAvoidance, IKProblem, JointPositionLimits, Kinematics, PositionTask
from wbik.scenarios import load_scenario, run_scenario
from wbik.scenarios.kinds import ScenarioValueError
from wbik.scenarios.schema import validate

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def one_joint_model() -> pin.Model:
    """A revolute joint about z at the origin carrying the frame 'link'."""
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    model.appendBodyToJoint(joint, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    model.addBodyFrame("link", joint, pin.SE3.Identity(), 0)
    return model


@pytest.fixture(scope="module")
def golem():
    return wbik.load("golem3")


@pytest.fixture(scope="module")
def golem_collisions(golem):
    return robot_collision_model(golem)


@pytest.mark.parametrize("length", [0.3, 0.8])
@pytest.mark.parametrize("theta", [0.4, -1.1])
def test_capsule_distance_matches_hand_geometry(length, theta):
    # a vertical post (radius 0.05) at (0.5, 0), z in [0, 1], fixed to the world; an arm capsule
    # (radius 0.04) from the joint axis along the link's x at z = 0.3, turned by theta about z
    model = one_joint_model()
    primitives = [capsule("post", "universe", (0.5, 0.0, 0.0), (0.5, 0.0, 1.0), 0.05),
                  capsule("arm", "link", (0.0, 0.0, 0.3), (length, 0.0, 0.3), 0.04)]
    collisions = CollisionModel(model, primitives, pairs=[("post", "arm")])
    (pair,) = collisions.distances(np.array([theta]))
    # hand geometry in the plane z = 0.3 (inside the post's span): the post is the point (0.5, 0),
    # the arm the segment from 0 to length * (cos theta, sin theta)
    direction = np.array([np.cos(theta), np.sin(theta)])
    t = np.clip(np.array([0.5, 0.0]) @ direction, 0.0, length)
    expected = np.linalg.norm(np.array([0.5, 0.0]) - t * direction) - 0.05 - 0.04
    assert pair.distance == pytest.approx(expected, abs=1e-9)
    # witness points on the surfaces, normal from a (post) to b (arm)
    assert np.linalg.norm(pair.point_b - pair.point_a) == pytest.approx(expected, abs=1e-9)
    assert pair.normal @ (pair.point_b - pair.point_a) == pytest.approx(expected, abs=1e-9)
    assert pair.point_a[2] == pytest.approx(0.3, abs=1e-9)


def test_overlap_is_negative_and_box_distance():
    model = one_joint_model()
    primitives = [capsule("arm", "link", (0.0, 0.0, 0.3), (0.6, 0.0, 0.3), 0.04)]
    # a box whose top face is 0.1 m under the arm's axis: distance 0.1 - 0.04
    table = Obstacle("table", (1.0, 1.0, 0.1), (0.3, 0.0, 0.15))
    wall = Obstacle("wall", (0.1, 1.0, 1.0), (0.58, 0.0, 0.5))  # overlaps the arm's tip by 0.09
    collisions = CollisionModel(model, primitives, [table, wall], pairs=[("arm", "table"), ("arm", "wall")])
    on_table, in_wall = collisions.distances(np.array([0.0]))
    assert on_table.distance == pytest.approx(0.06, abs=1e-7)
    assert in_wall.distance == pytest.approx(-(0.6 + 0.04 - 0.53), abs=1e-6)


def test_pairs_leave_out_same_joint_adjacent_and_nominal_contacts(golem, golem_collisions):
    excluded = golem_collisions.excluded
    assert excluded[("r_upper_arm", "r_forearm")] == "adjacent links"
    assert excluded[("r_shoulder", "r_upper_arm")].startswith("in contact")  # overlap at the nominal pose
    assert ("r_hand", "l_hand") in golem_collisions.pairs
    at_nominal = golem_collisions.distances(golem.nominal)
    assert min(d.distance for d in at_nominal) > 0.0
    assert len(golem_collisions.pairs) + len(excluded) == 12 * 11 // 2


@pytest.mark.parametrize("robot_name", ["golem3", "bioloid", "ur5"])
def test_constraint_row_matches_finite_differences(robot_name):
    robot = wbik.load(robot_name)
    collisions = robot_collision_model(robot)
    rng = np.random.default_rng(7)
    q = pin.integrate(robot.model, robot.nominal, 0.3 * rng.standard_normal(robot.model.nv))
    if robot.model.nq == robot.model.nv:
        q = np.clip(q, robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
    constraint = CollisionAvoidance(collisions, safety_distance=0.0, influence_distance=10.0)
    kinematics = Kinematics(robot.model, q)
    constraint.start(kinematics)
    G, h = constraint.inequality(kinematics)
    pairs = constraint.distances(kinematics)
    assert G.shape == (len(pairs), robot.model.nv)
    np.testing.assert_allclose(h, [p.distance - 1e-6 for p in pairs], atol=1e-12)
    direction = rng.standard_normal(robot.model.nv)
    step = 1e-6
    plus = collisions.distances(pin.integrate(robot.model, q, step * direction))
    minus = collisions.distances(pin.integrate(robot.model, q, -step * direction))
    checked = 0
    for row, pair, a, b in zip(G, pairs, plus, minus, strict=True):
        if pair.distance <= 1e-3:
            continue  # overlapping shapes: coal's penetration depth is not what this checks
        numeric = (a.distance - b.distance) / (2 * step)
        assert -row @ direction == pytest.approx(numeric, abs=2e-5 * max(1.0, abs(numeric))), (pair.a, pair.b)
        checked += 1
    assert checked >= 10


def two_gripper_problem(golem, collisions, separation, with_constraint, safety=0.02):
    targets = {"r_eef": [0.55, -separation / 2, 1.25], "l_eef": [0.55, separation / 2, 1.25]}
    tasks = [PositionTask(frame, np.array(target)) for frame, target in targets.items()]
    constraints = [JointPositionLimits()]
    if with_constraint:
        constraints.append(CollisionAvoidance(collisions, safety, 0.1))
    return IKProblem(golem.model, tasks, constraints).solve(golem.nominal, max_iterations=300)


def test_grippers_pulled_together_stop_at_the_safety_distance(golem, golem_collisions):
    safety = 0.02
    free = two_gripper_problem(golem, golem_collisions, 0.0, with_constraint=False)
    assert free.success  # both grippers at one point: the hands overlap
    assert golem_collisions.minimum(free.q).distance < safety
    held = two_gripper_problem(golem, golem_collisions, 0.0, with_constraint=True)
    closest = golem_collisions.minimum(held.q)
    assert closest.distance >= safety - 1e-4
    assert held.feasible and not held.success  # best effort, the constraint active
    assert {closest.a, closest.b} == {"r_hand", "l_hand"}
    assert closest.distance == pytest.approx(safety, abs=1e-4)
    violation = held.violations["collision avoidance (safety 20 mm)"]
    assert violation == pytest.approx(max(safety - closest.distance, 0.0), abs=1e-12)


def test_targets_far_enough_apart_are_reached_with_the_constraint(golem, golem_collisions):
    held = two_gripper_problem(golem, golem_collisions, 0.14, with_constraint=True)
    assert held.success and golem_collisions.minimum(held.q).distance >= 0.02


def test_bad_input_raises_typed_errors(golem, golem_collisions):
    model = one_joint_model()
    with pytest.raises(RobotDescriptionError, match="shape"):
        CollisionModel(model, [Primitive("b", "link", "cone", (0.1,))])
    with pytest.raises(RobotDescriptionError, match="size"):
        CollisionModel(model, [box("b", "link", (0.1, -0.1, 0.1))])
    with pytest.raises(UnknownFrameError):
        CollisionModel(model, [capsule("c", "no_such_frame", (0, 0, 0), (1, 0, 0), 0.1)])
    with pytest.raises(RobotDescriptionError, match="moves relative"):  # r_eef turns with m13, m14
        CollisionModel(golem.model, [capsule("c", "r_arm_link3", "r_arm_link3", "r_eef", 0.05)])
    for bad in (-0.01, float("nan"), True):
        with pytest.raises(InvalidSettingError):
            CollisionAvoidance(golem_collisions, bad)
    with pytest.raises(InvalidSettingError, match="influence"):
        CollisionAvoidance(golem_collisions, 0.05, 0.02)
    with pytest.raises(WbikError):
        CollisionAvoidance(golem_collisions, 0.01).start(Kinematics(one_joint_model()))


# -- scenario files ------------------------------------------------------------------------------
@pytest.mark.numerics
def test_golem3_arms_close_file(golem, golem_collisions):
    report = run_scenario(TASKS / "golem3_arms_close.yaml")
    assert report["passed"]
    close, pulled = report["phases"]
    for phase in (close, pulled):
        measured = golem_collisions.minimum(np.array(phase["q"])).distance
        assert measured >= 0.02 - 1e-9
        assert phase["checks"]["collision"]["min_distance"] == pytest.approx(measured, abs=1e-12)
    assert close["success"] and not pulled["success"]
    # the hands (45 mm capsules) stop 2 x 45 + 20 = 110 mm apart instead of 60: 25 mm short each
    for error in (pulled["task_errors"]["PositionTask[r_eef]"], pulled["task_errors"]["PositionTask[l_eef]"]):
        assert error == pytest.approx(0.025, abs=1e-3)


@pytest.mark.numerics
def test_bioloid_swing_foot_file_needs_the_constraint():
    spec = load_scenario(TASKS / "bioloid_swing_foot.yaml")
    report = run_scenario(spec)
    assert report["passed"]
    robot = wbik.load("bioloid")
    collisions = robot_collision_model(robot, contact_distance=0.01)
    swing = report["phases"][-1]
    assert swing["success"] and collisions.minimum(np.array(swing["q"])).distance >= 0.01 - 1e-9
    spec.pop("collisions")  # the same phases without the constraint: the foot comes closer
    spec["phases"][-1]["expect"] = {"success": True}
    free = run_scenario(spec)["phases"][-1]
    assert free["success"] and collisions.minimum(np.array(free["q"])).distance < 0.01


@pytest.mark.numerics
def test_ur5_near_table_file():
    report = run_scenario(TASKS / "ur5_near_table.yaml")
    assert report["passed"]
    reach, pushed = report["phases"]
    robot = wbik.load("ur5")
    tcp = robot.frame_placement(np.array(pushed["q"]), "tcp").translation
    # the pin (2.5 mm radius) stops 10 mm above the table top z = 0
    assert tcp[2] == pytest.approx(0.0125, abs=1e-4)
    assert pushed["checks"]["collision"]["pair"] == ["tool_pin", "table"]
    assert reach["checks"]["collision"]["min_distance"] >= 0.01


def test_collisions_block_schema():
    base = {"kind": "wholebody_ik", "robot": "golem3",
            "phases": [{"tasks": [{"type": "position", "frame": "r_eef", "target": [0.5, 0, 1.2]}]}]}
    checked = validate({**base, "collisions": {}}, "x.yaml")
    assert checked["collisions"] == {"self_collision": True, "robot_obstacles": True, "boxes": [],
                                     "safety_distance": 0.01, "influence_distance": 0.1}
    assert validate(base, "x.yaml")["collisions"] is None
    with pytest.raises(ScenarioValueError, match="influence_distance"):
        validate({**base, "collisions": {"safety_distance": 0.2}}, "x.yaml")
    with pytest.raises(ScenarioValueError, match=r"boxes\[0\]"):
        validate({**base, "collisions": {"boxes": [{"size": [1, 1, 1]}]}}, "x.yaml")
    phase = {**base["phases"][0], "expect": {"collision_distance_min_m": 0.01}}
    with pytest.raises(ScenarioValueError, match="collisions"):
        validate({**base, "phases": [phase]}, "x.yaml")
