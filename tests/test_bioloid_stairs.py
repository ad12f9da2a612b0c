"""Bioloid half steps, the simulated stairs and the seed's stair state machine (bioloid.md 5.3, 5.6, 6.5).

Expected values come from the seed (thresholds 100 / 120 / 15, PSThreshold 1000 on two reads, a
3-sample moving average, the 30 mm step length) or are computed independently here (FK of the
planted soles, scipy's ConvexHull for the support polygon, hand ray casts)."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from scenario_pages import check_page, check_support, quiet_spec, watch
from scipy.spatial import ConvexHull

import wbik
from wbik.apps.bioloid import behaviours, sensors, stairs
from wbik.apps.bioloid.stairs import Staircase, StairStateMachine
from wbik.errors import InvalidConfigurationError, WbikError

TASKS = Path(__file__).resolve().parents[1] / "tasks"


@pytest.fixture(scope="module")
def robot():
    return wbik.load("bioloid")


def file_margin(name: str) -> float:
    return float(yaml.safe_load((TASKS / name).read_text())["margin"])


def hull_margin(robot, q, soles) -> float:
    """Distance of the CoM projection inside the convex hull of the soles' corners (scipy)."""
    points = []
    for sole in soles:
        placement = robot.frame_placement(q, sole)
        corners = np.asarray(robot.soles[sole]) @ placement.rotation.T + placement.translation
        points.append(corners[:, :2])
    hull = ConvexHull(np.vstack(points))
    com = robot.center_of_mass(q)[:2]
    return float(min(-(hull.equations[:, :2] @ com + hull.equations[:, 2])))


# -- half steps -------------------------------------------------------------------------------------
PRECEDING = {"WalkSR1": [], "WalkSL1": [], "WalkSR2": ["WalkSR1"], "WalkSL2": ["WalkSL1"],
             "BackSR": ["WalkSR1"], "BackSL": ["WalkSL1"]}
MOVED = {"WalkSR1": ("r_sole", 0.03), "WalkSL1": ("l_sole", 0.03), "WalkSR2": ("l_sole", 0.03),
         "WalkSL2": ("r_sole", 0.03), "BackSR": ("r_sole", -0.03), "BackSL": ("l_sole", -0.03)}
"""The foot each half step moves and how far along x (the seed's step length xm - xf = 30 mm)."""


@pytest.mark.parametrize("name", list(PRECEDING))
def test_half_step_balanced_contacts_held_by_fk(robot, name):
    margin = file_margin("bioloid_half_steps.yaml")
    q0 = robot.nominal
    if PRECEDING[name]:
        q0 = behaviours.half_step_sequence(robot, PRECEDING[name], margin=margin).motion.q[-1]
    result = behaviours.half_step_sequence(robot, [name], q0, margin=margin)
    motion = result.motion
    moved, shift = MOVED[name]
    other = "l_sole" if moved == "r_sole" else "r_sole"
    start = {sole: robot.frame_placement(q0, sole) for sole in ("r_sole", "l_sole")}
    for q, support in zip(motion.q[1:], motion.support[1:], strict=True):
        assert hull_margin(robot, q, support) >= margin - 1e-9
        reached = robot.frame_placement(q, other)  # the foot that stays never moves
        assert np.linalg.norm(reached.translation - start[other].translation) <= 1e-6
        assert np.linalg.norm(reached.rotation - start[other].rotation) <= 1e-6
        if moved in support:  # the moved sole held where it was, or where it landed
            position = robot.frame_placement(q, moved).translation
            assert min(np.linalg.norm(position - start[moved].translation),
                       np.linalg.norm(position - start[moved].translation - [shift, 0, 0])) <= 1e-6
        low, high = robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]
        assert np.all(q[7:] >= low - 1e-9) and np.all(q[7:] <= high + 1e-9)
    end = robot.frame_placement(motion.q[-1], moved).translation
    assert end - start[moved].translation == pytest.approx([shift, 0.0, 0.0], abs=1e-6)
    # a lifted foot really leaves the ground (15 mm bump) in the swing phase
    heights = [robot.frame_placement(q, moved).translation[2] for q in motion.q]
    assert max(heights) == pytest.approx(behaviours.HALF_STEP_LIFT, abs=1e-6)


def test_half_steps_refuse_the_wrong_start(robot):
    with pytest.raises(InvalidConfigurationError, match="from behind"):
        behaviours.half_step_sequence(robot, ["WalkSR2"])
    with pytest.raises(InvalidConfigurationError, match="back from in front"):
        behaviours.half_step_sequence(robot, ["BackSL"])
    with pytest.raises(InvalidConfigurationError, match="unknown half step"):
        behaviours.half_step_sequence(robot, ["WalkSX1"])


# -- sensors: moving average, PSThreshold, the Sharp model ----------------------------------------
def test_moving_average_of_three_samples():
    average = sensors.MovingAverage(3)
    assert average.add(900.0) == pytest.approx(900.0)
    assert average.add(1200.0) == pytest.approx(1050.0)
    assert average.add(0.0) == pytest.approx(700.0)
    assert average.add(3000.0) == pytest.approx(1400.0)  # (1200 + 0 + 3000) / 3: 900 dropped
    pair = sensors.MovingAverage(3)
    for sample in ([0, 3000], [3000, 0], [0, 0]):
        pair.add(sample)
    assert pair.value == pytest.approx([1000.0, 1000.0])


def test_ps_threshold_needs_two_consecutive_low_reads_of_both_front_sensors():
    detector = sensors.StepDownDetector()
    assert detector.update(999.9, 999.9) is False  # one low read is not enough
    assert detector.update(999.9, 0.0) is True  # two in a row
    detector.reset()
    assert detector.update(999.0, 999.0) is False
    assert detector.update(1000.0, 10.0) is False  # exactly 1000 is not "no pressure": starts over
    assert detector.update(10.0, 10.0) is False
    assert detector.update(10.0, 10.0) is True
    # with the filter: a foot stepping off an edge; raw front readings, 3-sample average, two reads
    average, detector = sensors.MovingAverage(3), sensors.StepDownDetector()
    raw = [[3000, 3000], [3000, 3000], [0, 0], [0, 0], [0, 0], [0, 0]]
    decisions = [detector.update(*average.add(sample)) for sample in raw]
    # averages: 3000, 3000, 2000, 1000 (not < 1000), 0, 0 -> detected at the 6th read
    assert decisions == [False, False, False, False, False, True]


def test_fsr_reading_law():
    # 5000 mV * F / (F + 1 N): 0.25 N is exactly PSThreshold 1000 mV
    assert sensors.fsr_reading_mv([0.0, 0.25, 1.0, 4.0]) == pytest.approx([0.0, 1000.0, 2500.0, 4000.0])


def test_sharp_fold():
    # Eq. 23 holds at and beyond the fold: the reading is the distance (100 mm reads 100)
    assert sensors.sharp_reading_mm([60.0, 100.0, 120.0, 300.0]) == pytest.approx([60.0, 100.0, 120.0, 300.0])
    # below the fold the ADC falls linearly: at 30 mm it is half the peak ADC
    peak = sensors.sharp_adc_value(60.0)
    expected = (3027.4 / (peak / 2)) ** 1.2134 * 10
    assert sensors.sharp_reading_mm(30.0) == pytest.approx(expected)
    assert expected > stairs.SHARP_IN_FRONT_THRESHOLD  # close to the riser reads "high" again
    assert sensors.sharp_reading_mm(np.inf) == pytest.approx(800.0)


def test_raycast_on_a_step_by_hand(robot):
    box = Staircase(steps=2, height=0.03, depth=0.16, start_x=0.2)
    # a horizontal beam 12 mm up hits the first riser; 40 mm up (over step 1) the second one
    assert box.raycast(np.array([0.05, 0.0, 0.012]), np.array([1.0, 0, 0])) == pytest.approx(0.15)
    assert box.raycast(np.array([0.05, 0.0, 0.04]), np.array([1.0, 0, 0])) == pytest.approx(0.31)
    assert box.raycast(np.array([0.05, 0.0, 0.07]), np.array([1.0, 0, 0])) == np.inf
    # the nominal robot's beams: toes at x = 0.05, so each reads 150 mm (beyond the fold: Eq. 23)
    for sole in ("r_sole", "l_sole"):
        origin, direction = sensors.sharp_ray(robot, robot.nominal, sole)
        assert origin[0] == pytest.approx(0.05) and direction == pytest.approx([1, 0, 0])
        assert 1e3 * box.raycast(origin, direction) == pytest.approx(150.0)
    # the swing sole's clearance to an edge: hypot of the x gap and the height difference
    corners = np.array([[0.19, 0.03, 0.05], [0.09, 0.03, 0.05], [0.09, -0.03, 0.05], [0.19, -0.03, 0.05]])
    assert box.edge_distance(corners) == pytest.approx(np.hypot(0.01, 0.02))
    assert box.penetration(corners) == 0.0
    corners[:, 0] += 0.02  # toes 10 mm past the riser, 20 mm above the tread: no penetration
    assert box.penetration(corners) == 0.0
    corners[:, 2] = 0.02  # below the 30 mm tread with the toes over it
    assert box.penetration(corners) == pytest.approx(0.01)


# -- the state machine ------------------------------------------------------------------------------
NO_PRESSURE = {"r": (0.0, 0.0), "l": (0.0, 0.0)}
PRESSED = {"r": (3000.0, 3000.0), "l": (3000.0, 3000.0)}


def test_proximity_flag_needs_both_readings_strictly_below_100():
    machine = StairStateMachine()
    assert machine.after_placement({"r": 100.0, "l": 50.0}, PRESSED).action == "walk"
    assert machine.proximity is False  # 100 is not < 100
    assert machine.after_placement({"r": 99.9, "l": 99.9}, PRESSED).action == "walk"
    assert machine.proximity is True


def test_in_front_needs_strictly_above_120_and_the_flag_or_a_climb():
    machine = StairStateMachine()
    # far readings (> 120) before any proximity: not a step (stairCont = 0, no flag)
    assert machine.after_placement({"r": 500.0, "l": 500.0}, PRESSED).action == "walk"
    machine.after_placement({"r": 90.0, "l": 95.0}, PRESSED)  # flag
    assert machine.after_placement({"r": 120.0, "l": 120.0}, PRESSED).action == "walk"  # 120 is not > 120
    assert machine.after_placement({"r": 120.1, "l": 60.0}, PRESSED).action == "up"
    machine.climbed()
    assert machine.stair_count == 1 and machine.proximity is False
    # after a climb (stairCont > 0) no flag is needed
    assert machine.after_placement({"r": 60.0, "l": 121.0}, PRESSED).action == "up"
    machine.climbed()
    machine.climbed()
    # stairCont = 3: no more climbing
    assert machine.after_placement({"r": 500.0, "l": 500.0}, PRESSED).action == "walk"


@pytest.mark.parametrize(("right", "left", "turn"), [
    (150.0, 135.0, None), (150.1, 135.0, "right"), (135.0, 150.0, None), (135.0, 150.1, "left"),
    (200.0, 200.0, None)])
def test_turn_on_the_difference_threshold_15(right, left, turn):
    assert StairStateMachine.turn({"r": right, "l": left}) == turn


def test_step_down_only_after_three_climbs_and_two_low_reads():
    machine = StairStateMachine()
    far = {"r": 80.0, "l": 80.0}
    for _ in range(3):  # before three climbs the FSRs are not looked at
        assert machine.after_placement(far, NO_PRESSURE).action == "walk"
    machine.stair_count = 3
    low_left = {"r": (3000.0, 3000.0), "l": (999.0, 500.0)}
    assert machine.after_placement(far, low_left, forward_foot="l").action == "walk"
    decision = machine.after_placement(far, low_left, forward_foot="l")
    assert (decision.action, decision.foot) == ("back_then_down", "l")  # BackSL, then DownStair
    beside = StairStateMachine(stair_count=3)
    low_right = {"r": (10.0, 10.0), "l": (3000.0, 3000.0)}
    beside.after_placement(far, low_right)
    decision = beside.after_placement(far, low_right)
    assert (decision.action, decision.foot) == ("down", "r")  # next to the other foot: DownStair at once
    interrupted = StairStateMachine(stair_count=3)
    interrupted.after_placement(far, low_right)
    interrupted.after_placement(far, {"r": (10.0, 1000.0), "l": (3000.0, 3000.0)})  # FSR4 at 1000
    assert interrupted.after_placement(far, low_right).action == "walk"


# -- the stair run ----------------------------------------------------------------------------------
def test_stair_scenario_goes_up_and_down_again(tmp_path):
    """The task file as shipped, and its page (the checks of tests/test_view_every_task.py, here so that
    the stairs run once)."""
    path = TASKS / "bioloid_stairs.yaml"
    spec = quiet_spec(path, tmp_path)
    typed, animation, viewer, commands, size = watch(path, spec, tmp_path)
    report = typed.as_dict()
    assert report["passed"], report["verdict"]
    assert typed.animation is animation and report["animation_frames"] == animation.frames
    assert animation.frames >= 20 and animation.times[-1] > animation.times[0]
    check_page(animation, viewer, commands, size)
    check_support(animation, commands)
    entry = report["behaviours"][0]
    steps = spec["stairs"]["steps"]
    assert spec["stairs"]["descend"]
    assert entry["climbed"] == steps and entry["reached_top"]
    assert entry["descended"] == steps and entry["reached_bottom"]
    assert entry["states"].count("UpStair") == steps and entry["states"].count("DownStair") == steps
    margin = float(spec["margin"])
    robot = animation.robot
    for record in entry["per_sample"]:
        assert record["com_margin_m"] >= margin - 1e-9
        assert record["clearance_m"] is None or record["clearance_m"] >= 0.0
        assert record["penetration_m"] <= 1e-6
    # independent FK: both soles end flat on the floor beyond the staircase, the CoM inside their hull
    stairs_geometry = Staircase(**spec["stairs"])
    cop = animation.overlays.cop  # measured in physics only: the simulated run follows the planned one
    planned_frames = int(np.argmax(~np.all(np.isnan(cop), axis=1)))
    assert 0 < planned_frames < animation.frames and not np.isnan(cop[-1]).all()
    final = animation.configurations[planned_frames - 1]
    for sole in ("r_sole", "l_sole"):
        placement = robot.frame_placement(final, sole)
        assert placement.translation[2] == pytest.approx(0.0, abs=1e-6)
        assert placement.translation[0] - 0.05 > stairs_geometry.end_x  # the heel past the last riser
        assert placement.rotation[2, 2] == pytest.approx(1.0, abs=1e-9)
    assert hull_margin(robot, final, ("r_sole", "l_sole")) >= margin - 1e-9
    # the Sharp readings seen by the machine: proximity (both < 100) before the first climb
    reads = entry["reads"]
    first_up = next(i for i, r in enumerate(reads) if r["after"] == "UpStair")
    assert any(max(r["sharp_mm"].values()) < 100 for r in reads[:first_up])
    assert any(max(r["sharp_mm"].values()) > 120 for r in reads[:first_up])
    # FSRs: on the way up both feet stand wholly on a tread at every read, every front sensor well above
    # PSThreshold; before each DownStair a foot over the nose read both front sensors under it, twice
    last_up = max(i for i, r in enumerate(reads) if r["after"] == "UpStair")
    front = [min(min(v) for v in r["front_fsr_mv"].values()) for r in reads[:last_up]]
    assert all(value > sensors.PS_THRESHOLD for value in front)
    downs = [i for i, r in enumerate(reads) if r["after"] == "DownStair"]
    assert len(downs) == steps
    for index in downs:
        before = [r for r in reads[:index] if r["after"] not in ("DownStair", "UpStair")][-2:]
        assert any(all(max(r["front_fsr_mv"][side]) < sensors.PS_THRESHOLD for r in before) for side in "rl")
    assert planned_frames <= len(entry["per_sample"])
    # in MuJoCo: the figures judged as the file declares, per behaviour run in time order from t = 0
    physics = entry["physics"]
    checks = {check["name"]: check for check in entry["expectations"]}
    assert checks["physics_fell"]["figure"] is physics["fell"]
    assert checks["physics_cop_margin_min_m"]["figure"] == physics["cop_margin_min_m"]
    runs = physics["per_behaviour"]
    assert runs[0]["behaviour"] == "WalkSR1" and runs[0]["from_s"] == pytest.approx(0.0, abs=1e-9)
    for before, after in zip(runs[:-1], runs[1:], strict=True):
        assert before["to_s"] == pytest.approx(after["from_s"], abs=1e-9)
    assert 0 <= physics["simulated_s"] - runs[-1]["to_s"] < physics["tick_s"]  # a fall ends a tick early
    assert min(r["cop_margin_min_m"] for r in runs) == physics["cop_margin_min_m"]
    assert physics["fell"] == (physics["simulated_s"] < physics["planned_s"])
    # every stair step, up and down, was run in physics (the verdict above judged it stood, the CoP inside)
    stair_runs = {r["behaviour"] for r in runs if "Stair " in r["behaviour"]}
    assert stair_runs == {f"{way} {k}" for way in ("UpStair", "DownStair") for k in range(1, steps + 1)}


def test_a_foot_into_a_riser_is_refused(robot):
    # toes 10 mm from the riser and no proximity yet: the half step would kick the step
    with pytest.raises(WbikError, match="off a surface"):
        stairs.simulate_stairs(robot, Staircase(steps=1, start_x=0.06))


def test_schema_refuses_unknown_stair_keys():
    from wbik.scenarios.kinds import UnknownScenarioKeyError
    from wbik.scenarios.schema import validate

    with pytest.raises(UnknownScenarioKeyError):
        validate({"kind": "bioloid_stairs", "stairs": {"steps": 2, "riser": 0.03}}, "test")
    spec = validate({"kind": "bioloid_stairs"}, "test")
    assert spec["stairs"]["height"] == Staircase().height
