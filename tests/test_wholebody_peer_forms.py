"""A new task in one place: its class, its task-file entry and its peers' forms declared together, as
docs/architecture.md says, then used from a task-file mapping through wbik.scenarios.run_scenario and
solved by qp, PlaCo and mink, while Pink, which has no form for it, says so in its result.

The toy task holds one frame's height (world z, m). The peers' forms, and what a peer without a form
for a task or a constraint reports (:class:`wbik.qp.peers.Unsupported`), are checked on their own too.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import wbik
from wbik.qp.distances import MinimumDistance
from wbik.qp.kinematics import Kinematics
from wbik.qp.peers import PeerForms, Unsupported, largest_weight
from wbik.qp.task_entries import FRAME, TASK_ENTRY_REGISTRY, TaskEntry, build_task, register_task_entry
from wbik.qp.tasks import FrameTask, Task
from wbik.registry import RegistryError
from wbik.scenarios import run_scenario
from wbik.schema import Number
from wbik.solvers.mink import MINK
from wbik.solvers.pink import PINK
from wbik.solvers.placo import PLACO


# -- the new task: one module's worth -------------------------------------------------------------------
class HeightTask(Task):
    """One frame's height in the world: e = z - z* (m, 1 row)."""

    dimension = 1

    def __init__(self, frame: str, height: float, **options):
        self.frame, self.height, self.frame_id = frame, float(height), -1
        options.setdefault("name", f"HeightTask[{frame}]")
        super().__init__(**options)

    def start(self, kinematics: Kinematics) -> None:
        self.frame_id = kinematics.frame_id(self.frame)

    def error(self, kinematics: Kinematics) -> np.ndarray:
        return np.array([kinematics.placement(self.frame_id).translation[2] - self.height])

    def jacobian(self, kinematics: Kinematics) -> np.ndarray:
        return kinematics.jacobian(self.frame_id)[2:3]


def _height_entry(robot, q, entry, options) -> HeightTask:
    return HeightTask(entry["frame"], entry["height"], **options)


HEIGHT = TaskEntry("height", HeightTask, _height_entry, {"frame": FRAME, "height": Number(unit="m")},
                   required=("frame", "height"), description="a frame's height in the world")


@PLACO.form(HeightTask)
def _height_in_placo(task: HeightTask, placo) -> None:
    target = placo.kinematics.placement(task.frame_id).translation.copy()
    target[2] = task.height
    added = placo.solver.add_position_task(task.frame, target)
    added.mask.set_axises("z")  # PlaCo's masks are in world axes
    added.configure(task.name, "soft", largest_weight(task, 1.0))


@MINK.form(HeightTask)
def _height_in_mink(task: HeightTask, mink) -> None:
    from wbik.solvers.mink import site_position_task

    target = np.array([0.0, 0.0, task.height])
    cost = np.sqrt(largest_weight(task, 1.0))
    mink.tasks.append(site_position_task(mink.body.site(task.frame), target, [2], cost))
# (no form for Pink: it says so)


@pytest.fixture
def height_registered():
    with TASK_ENTRY_REGISTRY.isolated():
        register_task_entry(HEIGHT)  # the one registration line (or the module's name in TASK_ENTRY_MODULES)
        yield


def test_a_new_task_from_a_task_file_solved_by_qp_placo_mink_and_said_unsupported_by_pink(height_registered):
    bioloid = wbik.load("bioloid")
    start = bioloid.frame_placement(bioloid.nominal, "r_hand").translation
    report = run_scenario({
        "kind": "wholebody_ik", "name": "hand lower", "robot": "bioloid", "margin": 0.005,
        "methods": ["qp", "placo", "pink", "mink"],
        "phases": [{"name": "right hand 2 cm lower", "contacts": ["r_sole", "l_sole"],
                    "tasks": [{"type": "height", "frame": "r_hand", "height": float(start[2] - 0.02)}]}]})
    phase = report["phases"][0]
    assert report["passed"] and phase["success"], phase["reason"]
    height = start[2] - 0.02
    compared = phase["methods"]
    for q in (phase["q"], *(compared[method]["q"] for method in ("qp", "placo", "mink"))):
        reached = bioloid.frame_placement(np.array(q), "r_hand").translation
        assert reached[2] == pytest.approx(height, abs=1e-6)
    for method in ("qp", "placo", "mink"):
        assert compared[method]["success"], (method, compared[method]["reason"])
    assert compared["qp"]["unsupported"] == compared["placo"]["unsupported"] == []
    assert compared["mink"]["unsupported"] == [item for item in compared["mink"]["unsupported"]
                                               if "CoM in support polygon" in item]
    pink = compared["pink"]
    assert not pink["success"]  # without its only goal, Pink leaves the hand where it was
    assert ("unsupported by pink: task HeightTask[r_hand]: Pink has no form for HeightTask (a form registers "
            "with PINK.form of wbik.solvers.pink)") in pink["unsupported"]


def test_the_entry_type_is_checked_by_the_schema_and_by_build_task(height_registered):
    from wbik.scenarios.kinds import ScenarioError

    bioloid = wbik.load("bioloid")
    task = build_task(bioloid, bioloid.nominal, {"type": "height", "frame": "r_hand", "height": 0.1,
                                                 "weight": 2.0, "goal": True})
    assert isinstance(task, HeightTask) and task.height == 0.1 and np.all(task.weight == 2.0)
    spec = {"kind": "wholebody_ik", "robot": "bioloid",
            "phases": [{"contacts": ["r_sole"], "tasks": [{"type": "height", "frame": "r_hand"}]}]}
    with pytest.raises(ScenarioError, match=r"phases\[0\]\.tasks\[0\]: missing the required key 'height'"):
        run_scenario(spec)
    spec["phases"][0]["tasks"][0].update(height="high")
    with pytest.raises(ScenarioError, match=r"phases\[0\]\.tasks\[0\]\.height"):
        run_scenario(spec)


def test_without_the_registration_the_type_is_unknown():
    from wbik.qp.task_entries import TaskEntryError

    with TASK_ENTRY_REGISTRY.isolated(), pytest.raises(TaskEntryError, match="type 'height' is not allowed"):
        build_task(wbik.load("bioloid"), wbik.load("bioloid").nominal, {"type": "height", "frame": "r_hand"})


def test_a_task_entry_declares_its_keys_as_schema_nodes():
    with pytest.raises(RegistryError, match="each key is a wbik.schema node"):
        TaskEntry("bad", HeightTask, _height_entry, {"frame": "a frame please"})
    with pytest.raises(RegistryError, match="Task subclass"):
        TaskEntry("bad", dict, _height_entry)


# -- the forms --------------------------------------------------------------------------------------------
def test_a_subclass_takes_its_base_class_form_and_an_unknown_class_is_said():
    class MarkedFrameTask(FrameTask):
        pass

    bioloid = wbik.load("bioloid")
    marked = MarkedFrameTask("r_hand", bioloid.frame_placement(bioloid.nominal, "r_hand"))
    for forms in (PLACO, PINK, MINK):
        assert forms.refusal(marked) is None
        assert forms.lookup(MarkedFrameTask) is forms.lookup(FrameTask)
        assert forms.refusal(MinimumDistance("a", "b", 0.1))  # no peer keeps frame origins apart
    assert "has no form for HeightTask" in PINK.refusal(HeightTask("r_hand", 0.1))
    assert PLACO.refusal(HeightTask("r_hand", 0.1)) is None  # registered above


def test_a_form_is_registered_once_unless_replaced():
    forms = PeerForms("toy", "Toy")
    forms.cannot(HeightTask, "no heights")
    assert forms.refusal(HeightTask("r_hand", 0.1)) == "no heights"
    with pytest.raises(RegistryError, match="already has a form for HeightTask"):
        forms.cannot(HeightTask, "again")
    forms.form(HeightTask, refuse=lambda task: "too high" if task.height > 1 else None, replace=True)(print)
    assert forms.refusal(HeightTask("r_hand", 0.1)) is None
    assert forms.refusal(HeightTask("r_hand", 2.0)) == "too high"


def test_unsupported_is_a_typed_string_that_survives_pickling():
    item = Unsupported("pink", "task hand", "no form")
    assert item == "unsupported by pink: task hand: no form" and isinstance(item, str)
    again = pickle.loads(pickle.dumps(item))
    assert (again.peer, again.what, again.why) == ("pink", "task hand", "no form") and again == item


def test_peers_list_priorities_and_constraints_they_cannot_state():
    from wbik.qp.tasks import ComTask
    from wbik.wholebody.problem import WholeBody

    bioloid = wbik.load("bioloid")
    problem = WholeBody(bioloid, [ComTask([0.0, 0.0, 0.0], axes="xy"), HeightTask("r_hand", 0.1, priority=1)],
                        contacts=["r_sole", "l_sole"], collisions=[("r_hand", "l_hand", 0.05)],
                        acceleration_limit=10.0)
    for method in ("placo", "pink", "mink"):
        missing = wbik.solver(method, bioloid).unsupported(problem)
        assert all(isinstance(item, Unsupported) and item.peer == method for item in missing)
        what = [item.what for item in missing]
        assert "strict priority levels" in what and "joint acceleration limits" in what
        assert "distance(r_hand, l_hand) >= 0.05 m" in what
        assert ("task HeightTask[r_hand]" in what) == (method == "pink")
        assert ("CoM in support polygon (margin 5 mm)" in what) == (method != "placo")


@pytest.mark.parametrize("method", ["qp", "placo", "pink", "mink"])
def test_a_posture_on_some_joints_moves_those_joints_only(method):
    """A posture on the left elbow alone (weight 1, 0.3 rad away) beside a small reach of the right hand:
    every method brings that elbow to its reference, and none has anything to say against the task."""
    from wbik.qp.tasks import PositionTask, PostureTask
    from wbik.wholebody.problem import WholeBody

    bioloid = wbik.load("bioloid")
    q0 = bioloid.nominal
    elbow = bioloid.model.joints[bioloid.model.getJointId("l_elbow")].idx_q
    reference = q0.copy()
    reference[elbow] += 0.3
    hand = bioloid.frame_placement(q0, "r_hand").translation + [0.01, 0.0, 0.01]
    problem = WholeBody(bioloid, [PositionTask("r_hand", hand), PostureTask(reference, joints=["l_elbow"],
                                                                            weight=1.0)],
                        contacts=["r_sole", "l_sole"], support=[])
    result = wbik.solver(method, bioloid).solve(problem, q0)
    assert result.success, result.reason
    assert result.q[elbow] - q0[elbow] == pytest.approx(0.3, abs=1e-6)
    assert result.unsupported == []
