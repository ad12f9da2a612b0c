"""The walk pattern generator, the multibody ZMP and the whole-body tracking (wbik.motion.walking).

Expected values are computed independently: the pendulum's ZMP from the CoM by finite differences
(x - (z/g) x''), a point mass's ZMP in closed form, the RNEA base wrench against the centroidal
rate, the footholds by forward kinematics, scipy's ConvexHull for support polygons.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

import wbik
from wbik.errors import InvalidConfigurationError
from wbik.motion.walking import (
    Feet,
    PreviewController,
    StepCommand,
    Timing,
    multibody_zmp,
    plan_footsteps,
    trajectory_derivatives,
    walk_pattern,
)
from wbik.motion.walking.multibody_zmp import zmp_of_wrench
from wbik.motion.walking.pattern import PreviewSettings
from wbik.motion.walking.swing import bump, quintic, swing_pose
from wbik.motion.walking.tracking import TrackingSettings, walk

TASKS = Path(__file__).resolve().parents[1] / "tasks"
GRAVITY = 9.80665
ARMS = tuple(f"{s}_{n}" for s in "rl" for n in ("shoulder_pitch", "shoulder_roll", "elbow"))
TIMING = Timing(0.2, 0.05, 0.3, 0.3)


def zmp_from_base_wrench(model: pin.Model, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                         ground_z: float = 0.0) -> np.ndarray:
    """The ZMP from the free flyer's RNEA wrench: an independent path to multibody_zmp's."""
    data = model.createData()
    tau = pin.rnea(model, data, q, v, a)
    pin.forwardKinematics(model, data, q)  # (RNEA works in the joints' frames; it leaves oMi alone)
    wrench = data.oMi[1].act(pin.Force(tau[:6]))
    return zmp_of_wrench(wrench.linear, wrench.angular, np.zeros(3), ground_z)


@pytest.fixture(scope="module")
def bioloid():
    return wbik.load("bioloid")


@pytest.fixture(scope="module")
def feet(bioloid):
    return Feet.of(bioloid)


def start_feet(robot, feet, q=None):
    q = robot.nominal if q is None else q
    return {side: robot.frame_placement(q, feet.frame(side)) for side in ("left", "right")}


# -- footsteps ---------------------------------------------------------------------------------------
def test_straight_footsteps_alternate_and_close(bioloid, feet):
    steps = plan_footsteps(start_feet(bioloid, feet), StepCommand(4, 0.03), feet)
    assert [s.side for s in steps] == ["left", "right", "left", "right", "left"]
    assert [round(s.placement.translation[0], 9) for s in steps] == [0.03, 0.06, 0.09, 0.12, 0.12]
    assert all(abs(s.placement.translation[1]) == pytest.approx(0.0385) for s in steps)


def test_sideways_footsteps_never_narrow_the_stance(bioloid, feet):
    start = start_feet(bioloid, feet)
    width = start["left"].translation[1] - start["right"].translation[1]
    steps = plan_footsteps(start, StepCommand(4, 0.0, 0.015), feet)
    assert steps[0].side == "left"  # the foot on the side the robot moves to goes first
    feet_now = dict(start)
    for step in steps:
        feet_now[step.side] = step.placement
        spacing = feet_now["left"].translation[1] - feet_now["right"].translation[1]
        assert spacing >= width - 1e-12
    assert spacing == pytest.approx(width)
    assert feet_now["left"].translation[1] - start["left"].translation[1] == pytest.approx(0.06)


def test_turning_in_place_turns_both_feet(bioloid, feet):
    steps = plan_footsteps(start_feet(bioloid, feet), StepCommand(4, 0.0, 0.0, 15.0), feet)
    assert steps[0].side == "left"
    assert steps[-1].yaw == pytest.approx(math.radians(60))
    assert [s for s in steps if s.side == "right"][-1].yaw == pytest.approx(math.radians(60))
    with pytest.raises(InvalidConfigurationError):
        StepCommand(2, 0.0, 0.0, 60.0)


# -- the swing ---------------------------------------------------------------------------------------
def test_swing_leaves_and_meets_the_ground_at_rest():
    lift, land = pin.SE3.Identity(), pin.SE3(pin.utils.rotate("z", 0.3), np.array([0.06, 0.01, 0.0]))
    assert bump(0.5) == 1.0 and quintic(0.5) == 0.5
    h = 1e-6
    for tau in (0.0, 1.0):  # zero velocity of every coordinate at lift-off and touch-down
        ahead, behind = (swing_pose(lift, land, min(max(tau + d, 0.0), 1.0), 0.02) for d in (h, -h))
        assert np.linalg.norm(ahead.translation - behind.translation) / (2 * h) < 1e-4
    top = swing_pose(lift, land, 0.5, 0.02)
    assert top.translation[2] == pytest.approx(0.02) and top.translation[0] == pytest.approx(0.03)


# -- the pattern: preview control --------------------------------------------------------------------
def test_preview_holds_a_still_reference_and_tracks_a_step():
    controller = PreviewController(0.01, 0.18, 1.0, r=1e-6)
    still = controller.run(np.tile([0.3, -0.2], (200, 1)), [0.3, -0.2])
    assert np.abs(still.com - [0.3, -0.2]).max() < 1e-6  # no motion away from a balanced start
    t = 0.01 * np.arange(400)
    reference = np.column_stack([0.05 * np.clip((t - 1.0) / 0.2, 0.0, 1.0), np.zeros_like(t)])
    run = controller.run(reference, [0.0, 0.0])
    assert np.abs(run.zmp - reference).max() < 0.005
    assert run.com[-1] == pytest.approx([0.05, 0.0], abs=1e-4)


@pytest.mark.parametrize(("timing", "r", "after_start"), [(Timing(0.4, 0.2, 0.6, 0.6), 1e-7, 5e-4),
                                                          (TIMING, 1e-5, 0.03)])
def test_pattern_zmp_is_the_pendulums_and_tracks_its_reference(bioloid, timing, r, after_start):
    pattern = walk_pattern(bioloid, bioloid.nominal, StepCommand(4, 0.03), timing, clearance=0.015,
                           zmp_forward=0.015, preview=PreviewSettings(r=r))
    # after the first double support (the robot starts at rest: a counter-movement, inside the
    # support) the pendulum's ZMP is on its reference: within 0.5 mm at 0.4 s steps, 30 mm at 0.2 s
    walking = (pattern.times >= timing.start_s) & (pattern.times < pattern.times[-1] - 0.05)
    # independently: x_zmp = x_c - (z_c / g) x_c'' with x_c'' by central differences of the CoM
    com = pattern.com[:, :2]
    acceleration = np.zeros_like(com)
    acceleration[1:-1] = (com[2:] - 2 * com[1:-1] + com[:-2]) / pattern.dt ** 2
    pendulum = com - pattern.com_height / GRAVITY * acceleration
    assert np.abs(pendulum - pattern.lipm_zmp)[walking].max() < 2e-3
    error = np.linalg.norm(pattern.lipm_zmp - pattern.zmp_reference, axis=1)
    assert error[walking].max() < after_start
    # the reference and the pendulum's ZMP inside the planned support (scipy's hull)
    for k in range(0, pattern.ticks, 3):
        corners = [np.asarray(bioloid.soles[f]) @ p.rotation.T + p.translation
                   for f, p in pattern.stance(k).items()]
        hull = ConvexHull(np.vstack(corners)[:, :2])
        for point, least in ((pattern.zmp_reference[k], 0.02), (pattern.lipm_zmp[k], 0.0)):
            assert min(-(hull.equations[:, :2] @ point + hull.equations[:, 2])) >= least
    assert pattern.com[-1, :2] == pytest.approx(pattern.zmp_reference[-1], abs=5e-3)  # settling


# -- the multibody ZMP ---------------------------------------------------------------------------------
def point_mass_model(mass: float = 2.0) -> pin.Model:
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
    model.appendBodyToJoint(joint, pin.Inertia(mass, np.zeros(3), 1e-9 * np.eye(3)), pin.SE3.Identity())
    return model


def test_multibody_zmp_of_a_point_mass_is_the_pendulums():
    model, dt, height = point_mass_model(), 0.005, 0.4
    t = dt * np.arange(400)
    x, y = 0.05 * np.sin(3.0 * t), 0.03 * np.cos(2.0 * t)
    qs = np.array([np.r_[xi, yi, height, 0.0, 0.0, 0.0, 1.0] for xi, yi in zip(x, y, strict=True)])
    velocity, acceleration = trajectory_derivatives(model, qs, dt)
    zmp = multibody_zmp(model, qs, velocity, acceleration, 0.0)
    expected = np.column_stack([x + height / GRAVITY * 9.0 * x, y + height / GRAVITY * 4.0 * y])
    assert np.abs(zmp - expected)[1:-1].max() < 1e-5
    # a ground 0.1 m higher: the pendulum is 0.1 m shorter
    higher = multibody_zmp(model, qs, velocity, acceleration, 0.1)
    assert higher[100, 0] == pytest.approx(x[100] + (height - 0.1) / GRAVITY * 9.0 * x[100], abs=1e-5)


def test_multibody_zmp_equals_the_rnea_base_wrench_on_a_walk(bioloid):
    rng = np.random.default_rng(3)
    model, dt = bioloid.model, 0.01
    base = bioloid.nominal
    qs = []
    for k in range(40):  # a smooth whole-body motion, the base turning and climbing too
        v = np.zeros(model.nv)
        v[:6] = [0.02 * k, 0.01 * k, 0.002 * k, 0.01 * k, -0.02 * k, 0.03 * k]
        v[6:] = 0.3 * np.sin(0.1 * k + rng.uniform(0, 1, model.nv - 6))
        qs.append(pin.integrate(model, base, v * dt * 5))
    qs = np.array(qs)
    velocity, acceleration = trajectory_derivatives(model, qs, dt)
    zmp = multibody_zmp(model, qs, velocity, acceleration, -0.01)
    for k in range(1, 39):
        assert zmp_from_base_wrench(model, qs[k], velocity[k], acceleration[k], -0.01) == pytest.approx(
            zmp[k], abs=1e-9)


def test_finite_differences_are_exact_for_a_constant_twist():
    model = point_mass_model()
    twist = np.array([0.3, -0.1, 0.2, 0.4, -0.5, 0.6])
    qs = np.array([pin.integrate(model, pin.neutral(model), twist * 0.01 * k) for k in range(10)])
    velocity, acceleration = trajectory_derivatives(model, qs, 0.01)
    assert np.abs(velocity - twist).max() < 1e-9 and np.abs(acceleration[1:-1]).max() < 1e-6


# -- whole-body tracking --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def short_walk(bioloid):
    settings = TrackingSettings(trunk="pelvis", locked=ARMS)
    return walk(bioloid, bioloid.nominal, StepCommand(3, 0.03), TIMING, clearance=0.015, settings=settings,
                zmp_forward=0.015, preview=PreviewSettings(r=1e-5))


def test_stance_feet_do_not_slip_and_the_swing_lands_on_its_footstep(bioloid, short_walk):
    pattern = short_walk.pattern
    for k in range(1, pattern.ticks):
        for frame, held in pattern.stance(k).items():
            reached = bioloid.frame_placement(short_walk.q[k], frame)
            assert np.linalg.norm(reached.translation - held.translation) < 5e-5
            assert np.linalg.norm(pin.log3(held.rotation.T @ reached.rotation)) < 5e-4
    end = short_walk.q[-1]
    for step in pattern.footsteps[-2:]:
        assert bioloid.frame_placement(end, step.frame).translation == pytest.approx(
            step.placement.translation, abs=5e-5)
    assert short_walk.failed == []


def test_walk_figures_judge_the_motion_on_the_full_model(bioloid, feet, short_walk):
    from wbik.motion.walking.figures import walk_figures

    pattern = short_walk.pattern
    figures, series = walk_figures(bioloid, feet, pattern.times, short_walk.q, pattern.support, 0.0, 0.005,
                                   pattern.com)
    assert figures["zmp_margin_min_m"] >= 0.005
    assert figures["com_error_max_m"] < 1e-3 and figures["foot_slip_max_m"] < 5e-5
    assert figures["swings"] == len(pattern.footsteps)
    assert figures["swing_clearance_min_m"] == pytest.approx(0.015, abs=1e-3)
    assert figures["swing_height_min_m"] > -1e-6
    assert figures["distance_m"] == pytest.approx(0.09, abs=1e-4)
    assert 0 < figures["joint_velocity_over_limit"] < 1
    # the margin figure from an independent hull of the FK soles at one single-support sample
    k = next(i for i in range(pattern.ticks) if len(pattern.support[i]) == 1)
    corners = [np.asarray(bioloid.soles[f]) @ bioloid.frame_placement(short_walk.q[k], f).rotation.T
               + bioloid.frame_placement(short_walk.q[k], f).translation for f in pattern.support[k]]
    hull = ConvexHull(np.vstack(corners)[:, :2])
    zmp = series["zmp"][k, :2]
    expected = min(-(hull.equations[:, :2] @ zmp + hull.equations[:, 2]))
    assert series["zmp_margin"][k] == pytest.approx(expected, abs=1e-9)


# -- the task files ---------------------------------------------------------------------------------
def run_file(name: str, keep, compare=None):
    from wbik.scenarios import load_scenario, run_scenario

    spec = load_scenario(TASKS / name)
    spec["walks"] = [spec["walks"][i] for i in keep]
    # judged on the plan here; in physics by tests/test_view_every_task.py (every walk of both files)
    spec.pop("physics", None)
    spec["expect"] = {key: value for key, value in spec["expect"].items() if not key.startswith("physics_")}
    if compare is not None:
        for item in spec["walks"]:
            item["compare"] = compare
    return run_scenario(spec, source=name)


def test_bioloid_walk_file_passes_with_its_expectations():
    """Two of the file's walks, compared with the static gait; every walk of the file, as shipped, is
    run and judged by tests/test_view_every_task.py (with the Talos file's)."""
    report = run_file("bioloid_walk_dynamic.yaml", [0, 2], compare=["static"])
    assert report["verdict"] == "PASSED", report
    straight = report["walks"][0]
    assert straight["speed_ratio_vs_static"] >= 2.0 and straight["zmp_margin_min_m"] >= 0.005
    assert straight["compared"]["static"]["zmp_margin_min_m"] < 0  # the static gait at 40 rpm is not


def test_talos_walk_file_passes_with_its_expectations():
    report = run_file("talos_walk.yaml", [0], compare=[])
    assert report["verdict"] == "PASSED", report
    assert report["walks"][0]["zmp_margin_min_m"] >= 0.02


def test_walk_schema_refuses_unknown_keys_with_a_guess():
    from wbik.scenarios.kinds import UnknownScenarioKeyError
    from wbik.scenarios.schema import validate

    with pytest.raises(UnknownScenarioKeyError, match="did you mean 'clearance'"):
        validate({"kind": "walk", "robot": "bioloid", "clearence": 0.02, "walks": [{}]}, "w.yaml")
    with pytest.raises(UnknownScenarioKeyError, match="lateral"):
        validate({"kind": "walk", "robot": "bioloid", "walks": [{"laterl": 0.01}]}, "w.yaml")
    spec = validate({"kind": "walk", "robot": "bioloid", "walks": [{}]}, "w.yaml")
    assert spec["timing"] == {"single_support_s": 0.3, "double_support_s": 0.1, "start_s": 0.4, "end_s": 0.6}
    assert spec["walks"][0]["steps"] == StepCommand().steps


def test_no_garbage_collection_runs_inside_a_control_tick(bioloid, monkeypatch):
    """The walk's tick loops run with the cyclic collector off (a collection of the old generations
    took up to ~1 ms of CPU inside about one tick in 300), and leave it as they found it."""
    import gc

    from wbik.motion.walking import tracking
    from wbik.motion.walking.control_loop import without_cyclic_gc

    seen = []
    step = tracking.Tracker.step

    def recording_step(self, q, pattern, k):
        seen.append(gc.isenabled())
        return step(self, q, pattern, k)

    monkeypatch.setattr(tracking.Tracker, "step", recording_step)
    assert gc.isenabled()
    settings = TrackingSettings(trunk="pelvis", locked=ARMS)
    walk(bioloid, bioloid.nominal, StepCommand(1, 0.02), TIMING, clearance=0.015, settings=settings)
    assert seen and not any(seen)
    assert gc.isenabled()
    gc.disable()
    try:
        with without_cyclic_gc():
            pass
        assert not gc.isenabled()  # a caller's own choice is kept
    finally:
        gc.enable()


def test_a_robot_without_package_shapes_gets_its_legs_kept_apart_from_the_task_file():
    """Talos from example-robot-data lists no collision primitives; the walk file's leg capsules give
    the tracking QP its left-right leg pairs."""
    import yaml

    from wbik.data import shipped_tasks
    from wbik.motion.walking.scenario import _spec_objects
    from wbik.motion.walking.tracking import leg_collision_model
    from wbik.scenarios.schema import validate

    spec = validate(yaml.safe_load(shipped_tasks()["talos_walk"].read_text()), "talos_walk.yaml")
    robot = wbik.load(spec["robot"], **spec["robot_params"])
    feet, _, _, settings = _spec_objects(spec, robot)
    assert len(settings.leg_capsules) == 4
    model = leg_collision_model(robot, feet, settings.leg_capsules)
    assert len(model.pairs) == 4  # thigh and shin of one leg against thigh and shin of the other
    assert min(pair.distance for pair in model.distances(robot.nominal)) > 0.04
    assert leg_collision_model(robot, feet) is None  # without them: no shapes, no pairs


# -- the feedforward from the plan --------------------------------------------------------------------------
def test_the_start_leaves_rest_and_meets_the_reference_where_the_first_step_begins():
    """p = xi - xi'/omega with xi(0) = c0 and xi'(0) = 0 starts at the CoM; at T_s, xi' = omega (xi_s -
    p_ref(T_s)) gives p = p_ref(T_s); in between, the reference moves by less than it did."""
    from wbik.motion.walking.feedforward import rest_start

    omega, com = math.sqrt(9.80665 / 0.2), np.array([0.001, 0.002, 0.2])
    gaps = []
    for dt in (0.01, 0.001):  # the start's 0.3 s at two rates
        ticks = int(round(0.3 / dt))
        t = dt * np.arange(int(round(2.0 / dt)))
        reference = np.column_stack([0.02 * np.tanh(5 * t), -0.03 * np.clip(t / 0.2, 0, 1)])
        shaped = rest_start(reference, com, ticks, omega, dt)
        assert shaped[0] == pytest.approx(com[:2], abs=1e-12)
        assert np.array_equal(shaped[ticks:], reference[ticks:])
        gaps.append(np.abs(shaped[ticks - 1] - reference[ticks]).max())
    assert gaps[1] < 0.2 * gaps[0] and gaps[1] < 1e-4  # the gap is one tick of motion: continuous at T_s


def test_the_feedforward_keeps_the_multibody_zmp_inside_in_one_pass(bioloid):
    """The sideways walk of tasks/bioloid_walk_dynamic.yaml: without the feedforward its multibody ZMP comes
    within 1 mm of the sole's edge; with it (one plan, one tracking pass) it keeps the file's 5 mm."""
    from wbik.motion.walking.figures import walk_figures
    from wbik.scenarios import load_scenario

    spec = load_scenario(TASKS / "bioloid_walk_dynamic.yaml")
    item = spec["walks"][2]
    assert item["name"].startswith("sideways")
    settings = TrackingSettings(trunk=spec["trunk"], locked=tuple(spec["locked"]))
    timing = Timing(**{**spec["timing"], **item["timing"]})
    margins = {}
    for feedforward in (False, True):
        motion = walk(bioloid, bioloid.nominal, StepCommand(item["steps"], 0.0, item["lateral"]), timing,
                      clearance=spec["clearance"], settings=settings, zmp_forward=spec["zmp_forward"],
                      preview=PreviewSettings(**spec["preview"]), feedforward=feedforward)
        pattern = motion.pattern
        figures, _ = walk_figures(bioloid, Feet.of(bioloid), pattern.times, motion.q, pattern.support)
        margins[feedforward] = figures["zmp_margin_min_m"]
        assert motion.failed == []
    assert margins[False] < 0.002 and margins[True] >= 0.005
