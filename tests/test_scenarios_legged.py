"""The legged task files: Talos reaching on two flat feet, Solo12 moving its trunk on four point feet.

Each file is run once (qp for the phases, and qp, placo, pink and mink compared on every phase). Every
figure is checked by forward kinematics and geometry computed here: contact placements against those
at the phase's start, the CoM margin against qhull's own half-planes of the contact points, the goals
against the targets the file states, joints against the model's limits. The compared methods need
not succeed (Pink and mink have no hard support polygon), but what each reports must agree with these
independent figures and with the shared check's rule (goals and contacts within 1e-6, CoM margin at
least the phase's margin, joints inside their limits).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from wbik.scenarios import load_scenario, run_scenario_report

TASKS = Path(__file__).resolve().parents[1] / "tasks"
TOLERANCE = 1e-6  # m and rad: the shared check's default tolerances
METHODS = {"qp", "placo", "pink", "mink"}
NO_HARD_POLYGON = {"pink", "mink"}


class Run:
    """A task file, its spec, its report and its robot, and each phase's start configuration."""

    def __init__(self, name: str):
        self.spec = load_scenario(TASKS / f"{name}.yaml")
        self.report = run_scenario_report(TASKS / f"{name}.yaml")
        self.robot = self.report.animation.robot
        self.phases = self.report.figures["phases"]
        self.starts = []
        q = self.robot.nominal.copy()
        for phase in self.spec["phases"]:
            self.starts.append(q)
            if phase.get("continue_from", "result") == "result":
                q = np.array(self.phases[len(self.starts) - 1]["q"])

    def sole_points(self, frame: str) -> np.ndarray:
        """The file's contact points of a sole, in its frame, from the file's own numbers."""
        entry = next(e for e in self.spec["soles"] if e["frame"] == frame)
        if "point" in entry:
            return np.array([entry["point"]], dtype=float)
        length, width = entry["size"]
        centre = np.array(entry.get("centre", [0.0, 0.0, 0.0]))
        return centre + np.array([[sx * length / 2, sy * width / 2, 0.0]
                                  for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])


@pytest.fixture(scope="module")
def talos():
    return Run("talos_reach")


@pytest.fixture(scope="module")
def solo():
    return Run("solo12_trunk")


def placement(robot, q, frame) -> pin.SE3:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.model.getFrameId(frame)]


def hull_margin(run: Run, q, support) -> float:
    """Distance of the CoM's ground projection inside the hull of the support's contact points, from
    qhull's half-planes (n . x + c <= 0, n unit): min over facets of -(n . com + c)."""
    points = np.array([placement(run.robot, q, frame).act(point) for frame in support
                       for point in run.sole_points(frame)])[:, :2]
    com = pin.centerOfMass(run.robot.model, run.robot.model.createData(), q)[:2]
    equations = ConvexHull(points).equations
    return float(np.min(-(equations[:, :2] @ com + equations[:, 2])))


def contact_drift(run: Run, q, start, contacts) -> float:
    """Largest contact error: position, and rotation angle for a flat sole (a point foot may roll)."""
    drift = 0.0
    for frame in contacts:
        held, reached = placement(run.robot, start, frame), placement(run.robot, q, frame)
        drift = max(drift, float(np.linalg.norm(reached.translation - held.translation)))
        if "point" not in next(e for e in run.spec["soles"] if e["frame"] == frame):
            drift = max(drift, float(np.linalg.norm(pin.log3(held.rotation.T @ reached.rotation))))
    return drift


def goal_error(run: Run, q, start, phase) -> float:
    """The error of the phase's goal task (its first task), from the file's target, offset and rpy."""
    task = phase["tasks"][0]
    before, reached = placement(run.robot, start, task["frame"]), placement(run.robot, q, task["frame"])
    position = np.array(task["target"]) if "target" in task else before.translation + task.get("offset", 0.0)
    error = float(np.linalg.norm(reached.translation - position))
    if task["type"] == "frame":
        rotation = pin.rpy.rpyToMatrix(*task["rpy"]) if "rpy" in task else before.rotation
        error = max(error, float(np.linalg.norm(pin.log3(rotation.T @ reached.rotation))))
    return error


def limit_excess(robot, q) -> float:
    model = robot.model
    rows = [model.joints[j].idx_q for j in range(1, model.njoints) if model.joints[j].nq == 1]
    return float(max(np.max(model.lowerPositionLimit[rows] - q[rows]),
                     np.max(q[rows] - model.upperPositionLimit[rows]), 0.0))


def check_qp_phases(run: Run) -> None:
    assert run.report.passed
    for spec_phase, phase, start in zip(run.spec["phases"], run.phases, run.starts, strict=True):
        q = np.array(phase["q"])
        margin = spec_phase.get("margin", run.spec["margin"])
        contacts = spec_phase["contacts"]
        assert phase["success"], (phase["name"], phase["reason"])
        assert hull_margin(run, q, spec_phase.get("support", contacts)) >= margin - 1e-9, phase["name"]
        assert contact_drift(run, q, start, contacts) <= TOLERANCE, phase["name"]
        assert goal_error(run, q, start, spec_phase) <= TOLERANCE, phase["name"]
        assert limit_excess(run.robot, q) <= 1e-9


def check_compared_methods(run: Run) -> dict:
    """Every phase reports qp, placo, pink and mink; each report agrees with the figures computed here
    and its success with the shared rule. Returns {method: phases solved}."""
    solved = dict.fromkeys(METHODS, 0)
    for spec_phase, phase, start in zip(run.spec["phases"], run.phases, run.starts, strict=True):
        assert set(phase["methods"]) == METHODS
        margin = spec_phase.get("margin", run.spec["margin"])
        contacts = spec_phase["contacts"]
        for method, figures in phase["methods"].items():
            q = np.array(figures["q"])
            assert figures["method"] == method and figures["time_s"] > 0 and figures["iterations"] >= 1
            com_margin = hull_margin(run, q, spec_phase.get("support", contacts))
            drift = contact_drift(run, q, start, contacts)
            error = goal_error(run, q, start, spec_phase)
            assert figures["com_margin"] == pytest.approx(com_margin, abs=1e-9), (phase["name"], method)
            assert figures["contact_drift"] == pytest.approx(drift, rel=1e-6, abs=1e-12)
            assert figures["task_error"] == pytest.approx(error, rel=1e-6, abs=1e-12)
            meets = (com_margin >= margin - 1e-9 and drift <= TOLERANCE and error <= TOLERANCE
                     and limit_excess(run.robot, q) <= 1e-9)
            assert figures["success"] == meets, (phase["name"], method, figures["reason"])
            assert figures["success"] or figures["reason"]
            if method in NO_HARD_POLYGON:  # said, not dropped silently
                (item,) = figures["unsupported"]
                assert item.startswith(f"unsupported by {method}: CoM in support polygon"), item
            else:
                assert figures["unsupported"] == []
            solved[method] += figures["success"]
    return solved


@pytest.mark.numerics
def test_talos_reaches_on_two_flat_feet_with_qp(talos):
    check_qp_phases(talos)
    # the far reach leans until the CoM margin is the file's 20 mm: the constraint is active
    far = talos.phases[1]
    margin = hull_margin(talos, np.array(far["q"]), far["support"])
    assert margin == pytest.approx(talos.spec["margin"], abs=1e-4)


@pytest.mark.numerics
def test_solo12_moves_its_trunk_on_point_feet_with_qp(solo):
    check_qp_phases(solo)
    three_feet = solo.phases[-1]
    assert len(three_feet["support"]) == 3
    q = np.array(three_feet["q"])
    before = placement(solo.robot, solo.starts[-1], "HR_FOOT").translation
    np.testing.assert_allclose(placement(solo.robot, q, "HR_FOOT").translation - before, [0.0, 0.0, 0.03],
                               atol=TOLERANCE)


def test_talos_methods_compared_by_the_shared_check(talos):
    solved = check_compared_methods(talos)
    assert solved["qp"] == len(talos.phases)


def test_solo12_methods_compared_by_the_shared_check(solo):
    solved = check_compared_methods(solo)
    assert solved["qp"] == len(solo.phases)


def test_solo12_animation_returns_to_the_start_between_phases_that_start_there(solo):
    """Phases with continue_from: start are each played from the standing pose: the animation's
    keyframes are answer 1, start, answer 2, start, ..., answer 6 (answer 5 is followed by the start,
    from which the three-feet phase was solved)."""
    from wbik.scenarios.wholebody import SAMPLES_PER_PHASE

    animation = solo.report.animation
    keyframes = animation.configurations[::SAMPLES_PER_PHASE]
    start = solo.robot.nominal
    expected = [start]
    for phase in solo.phases[:-1]:
        expected += [np.array(phase["q"]), start]
    expected.append(np.array(solo.phases[-1]["q"]))
    assert len(keyframes) == len(expected) == animation.frames // SAMPLES_PER_PHASE + 1
    for shown, q in zip(keyframes, expected, strict=True):
        np.testing.assert_allclose(shown, q, atol=1e-12)
