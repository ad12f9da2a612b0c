"""Riveting cell and a short run (a few holes) with both planners, checked independently."""

import numpy as np
import pinocchio as pin
import pytest

import wbik
from wbik.apps.riveting.cycle import NoiseModel, RunConfig, simulate
from wbik.apps.riveting.ours import QPPlanner
from wbik.apps.riveting.plan import Insertion
from wbik.apps.riveting.thesis import ThesisPlanner


@pytest.fixture(scope="module")
def cell(riveting_cell):
    return riveting_cell


def test_scene_has_33_holes_with_axes_into_the_workpiece(cell):
    _, scene, *_ = cell
    assert len(scene.holes) == 33
    assert [len(scene.holes_of(face)) for face in ("top", "right", "left")] == [11, 11, 11]
    for hole in scene.holes:
        inside = hole.point_at_depth(0.005) - scene.workpiece_center
        assert np.all(np.abs(inside) < scene.workpiece_half), hole.name  # 5 mm along z is inside the box
        assert np.isclose(np.linalg.det(hole.placement.rotation), 1.0)
    assert scene.minimum_hole_spacing() == pytest.approx(0.04)


def _tcp_pose_q(robot, pose, q0):
    return wbik.solver("analytic", robot, chain="arm").solve(pose, q0).q


def test_pin_in_hole_has_half_millimetre_clearance(cell):
    robot, scene, collision, _, _, q_home = cell
    hole = scene.hole("h3")
    pose = pin.SE3(hole.placement.rotation, hole.point_at_depth(0.006))
    clearance = collision.clearance(_tcp_pose_q(robot, pose, q_home))
    pin_distance = next(d for d in clearance.workpiece if d.geometry == "rivet_tool_1")
    assert pin_distance.exact
    assert pin_distance.distance == pytest.approx(0.0005, abs=1e-6)  # 3 mm wall - 2.5 mm pin
    # shifted 0.7 mm sideways, the pin is in the wall: penetration of 0.2 mm
    shifted = pin.SE3(pose.rotation, pose.translation + 0.0007 * hole.placement.rotation[:, 0])
    clearance = collision.clearance(_tcp_pose_q(robot, shifted, q_home))
    pin_distance = next(d for d in clearance.workpiece if d.geometry == "rivet_tool_1")
    assert pin_distance.distance == pytest.approx(-0.0002, abs=2e-5)


def test_pin_touching_the_hole_bottom(cell):
    robot, scene, collision, _, _, q_home = cell
    hole = scene.hole("h14")
    pose = pin.SE3(hole.placement.rotation, hole.point_at_depth(scene.hole_depth - 0.001))
    clearance = collision.clearance(_tcp_pose_q(robot, pose, q_home))
    pin_distance = next(d for d in clearance.workpiece if d.geometry == "rivet_tool_1")
    assert pin_distance.distance == pytest.approx(0.0005, abs=1e-6)  # radial gap still the smallest
    deeper = pin.SE3(hole.placement.rotation, hole.point_at_depth(scene.hole_depth + 0.001))
    clearance = collision.clearance(_tcp_pose_q(robot, deeper, q_home))
    assert next(d for d in clearance.workpiece if d.geometry == "rivet_tool_1").distance < 0.0


def test_noise_model_keeps_guesses_near_their_hole(cell):
    _, scene, *_ = cell
    rng = np.random.default_rng(1)
    model = NoiseModel()
    for hole in scene.holes:
        for _ in range(20):
            guess = model.guess(hole, rng)
            assert np.linalg.norm(guess.translation - hole.position) <= model.position_max
            assert scene.nearest_hole(guess.translation).name == hole.name


def _independent_checks(result, chain, scene, insertion):
    """Depth 6 mm +- 0.1 mm along the axis, lateral < 0.3 mm, no collision, recomputed by FK here."""
    triggers = [(start, move) for start, move in result.timeline if move.name == "trigger_rivet"]
    assert len(triggers) == len([c for c in result.cycles if c["success"]])
    holes = [scene.hole(c["hole"]) for c in result.cycles if c["success"]]
    for (_, move), hole in zip(triggers, holes, strict=True):
        tcp = chain.fk(move.hold)
        offset = tcp.translation - hole.position
        depth = offset @ hole.axis
        lateral = np.linalg.norm(offset - depth * hole.axis)
        assert abs(depth - insertion.depth) <= 1e-4
        assert lateral < 3e-4
        assert tcp.rotation[:, 2] @ hole.axis > np.cos(np.radians(1.0))
    assert result.collisions == 0
    for cycle in result.cycles:
        if cycle["success"]:
            assert cycle["tool_min_m"] > 0.0 and cycle["link_min_m"] > 0.0


@pytest.mark.parametrize("which", ["thesis", "ours"])
def test_short_run(cell, which):
    robot, scene, collision, chain, limits, q_home = cell
    insertion = Insertion()
    if which == "thesis":
        planner = ThesisPlanner(robot, scene, collision, limits, insertion, timing="optimal")
    else:
        planner = QPPlanner(robot, scene, collision, limits, insertion)
    result = simulate(planner, scene, collision, insertion, q_home, RunConfig(max_cycles=2, seed=7))
    assert sum(c["success"] for c in result.cycles) >= 1
    _independent_checks(result, chain, scene, insertion)
    assert result.rivets == sum(c["success"] for c in result.cycles)
    # every move respects the velocity and acceleration limits
    for _, move in result.timeline:
        if move.timed is not None:
            times = np.linspace(0.0, move.duration, 400)
            _, velocity, acceleration = move.timed.evaluate(times)
            assert np.all(np.abs(velocity) <= limits.velocity * (1 + 1e-6))
            assert np.all(np.abs(acceleration) <= limits.acceleration * (1 + 1e-3))


def test_pin_stays_in_its_hole_during_insertion(cell):
    """Between the QP knots the spline keeps the pin near the axis (0.5 mm of clearance)."""
    robot, scene, collision, chain, limits, q_home = cell
    planner = QPPlanner(robot, scene, collision, limits, Insertion())
    plan = planner.plan(scene.hole("h7"), q_home)
    assert plan.success, plan.reason
    insert = next(move for move in plan.moves if move.name == "insert")
    hole = scene.hole("h7")
    for q in insert.evaluate(np.linspace(0.0, insert.duration, 300)):
        offset = chain.fk(q).translation - hole.position
        lateral = np.linalg.norm(offset - (offset @ hole.axis) * hole.axis)
        assert lateral < 1e-4


@pytest.mark.parametrize("name", ["h14", "h16", "h27"])
def test_holes_near_the_joint_line_have_a_clear_route(cell, name):
    """h14, h15, h16, h20, h21, h27 need the retreat point (the direct joint line comes within 4.6 mm of
    the workpiece); three of them, checked as densely as the run."""
    from wbik.apps.riveting.cycle import check_move

    robot, scene, collision, chain, limits, q_home = cell
    planner = QPPlanner(robot, scene, collision, limits, Insertion())
    plan = planner.plan(scene.hole(name), q_home)
    assert plan.success, plan.reason
    assert plan.planning_cost_s > 0 and plan.info["planning_counts"]["clearance"] > 0
    assert np.allclose(plan.moves[0].start, q_home) and np.allclose(plan.moves[-1].end, q_home)
    previous = {}
    for move in plan.moves:
        check = check_move(move, chain, collision, previous)
        assert check.collisions == 0
        if move.name.startswith(("approach", "to rivet_home")):
            assert min(check.tool_min, check.link_min, check.table_min) > 0.002  # the certified 2 mm
    for first, second in zip(plan.moves[:-1], plan.moves[1:], strict=True):
        assert np.allclose(first.end, second.start, atol=1e-9)  # no jump between moves
