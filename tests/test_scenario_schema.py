"""Scenario files are checked against one schema (wbik.scenarios.schema) before anything runs.

Every file in tasks/ validates (no solving here); each hostile input raises its typed error naming
the file and the key's path; ``wbik run BAD.yaml`` exits 2 without a traceback.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wbik.errors import (
    InvalidBudgetError,
    InvalidOptionError,
    MissingDependencyError,
    UnknownMethodError,
    UnknownRobotError,
    WbikError,
)
from wbik.expectations import ExpectationError
from wbik.scenarios import load_scenario, run_scenario
from wbik.scenarios.kinds import (
    KIND_REGISTRY,
    ScenarioBudgetError,
    ScenarioError,
    ScenarioFileError,
    ScenarioValueError,
    UnknownScenarioKeyError,
)
from wbik.scenarios.schema import validate

TASKS = Path(__file__).resolve().parents[1] / "tasks"
WBIK = Path(sys.executable).parent / "wbik"
BALANCE = """kind: wholebody_ik
robot: bioloid
phases:
  - name: shift
    contacts: [r_sole, l_sole]
    tasks:
      - {type: com, over: r_sole, axes: xy}
      - {type: orientation, frame: pelvis, keep: true, weight: 0.1, goal: false}
"""


LEGGED = """kind: wholebody_ik
robot: example-robot-data:solo12
soles:
  - {frame: FL_FOOT, point: [0, 0, 0]}
  - {frame: FR_FOOT, point: [0, 0, 0]}
  - {frame: HL_FOOT, point: [0, 0, 0]}
methods: [qp, pink]
phases:
  - contacts: [FL_FOOT, FR_FOOT, HL_FOOT]
    tasks:
      - {type: frame, frame: base_link, offset: [0.01, 0, 0]}
"""


def write(tmp_path: Path, text: str, name: str = "bad.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("path", sorted(TASKS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_task_file_validates(path):
    spec = load_scenario(path)
    checked = validate(spec, str(path))
    assert checked["kind"] in KIND_REGISTRY.entries()
    assert set(spec) <= set(checked)  # nothing dropped; defaults added


def yaml_load(text: str):
    import yaml

    return yaml.safe_load(text)


@pytest.mark.parametrize("text, error, words", [
    (BALANCE.replace("{type: com, over: r_sole", "{type: com, ovr: r_sole"), UnknownScenarioKeyError,
     ["phases[0].tasks[0].ovr", "did you mean 'over'"]),
    (BALANCE.replace("frame: pelvis", "frme: pelvis"), UnknownScenarioKeyError,
     ["phases[0].tasks[1].frme", "did you mean 'frame'"]),
    (BALANCE.replace("{type: orientation, frame: pelvis,", "{type: orientation,"), ScenarioValueError,
     ["phases[0].tasks[1]", "required key 'frame'"]),
    (BALANCE.replace("    contacts:", "    contact:"), UnknownScenarioKeyError,
     ["phases[0].contact", "did you mean 'contacts'"]),
    (BALANCE.replace("robot: bioloid", "robot: bioloyd"), UnknownRobotError,
     ["bioloyd", "golem3", "robot"]),
    (BALANCE.split("phases:")[0] + "phases: 3\n", ScenarioValueError, ["phases", "list", "3 (int)"]),
    (BALANCE.replace("robot: bioloid", "robot: bioloid\nbackend: daqq"), ScenarioValueError,
     ["backend", "daqq", "did you mean 'daqp'"]),
    (BALANCE.replace("robot: bioloid", "robot: bioloid\nrobot_params: {tool_lenght: 0.07}"),
     InvalidOptionError, ["robot_params", "tool_lenght", "tool_length"]),
    (BALANCE.replace("    tasks:", "    max_iterations: .inf\n    tasks:"), ScenarioBudgetError,
     ["phases[0].max_iterations", "integer > 0"]),
    (BALANCE.replace("    tasks:", "    max_iterations: 0\n    tasks:"), InvalidBudgetError,
     ["phases[0].max_iterations", "0"]),
    (BALANCE.replace("axes: xy}", "axes: xy, weight: yes}"), ScenarioValueError,
     ["phases[0].tasks[0].weight", "number"]),
    (BALANCE.replace("type: com", "type: comm"), ScenarioValueError,
     ["phases[0].tasks[0].type", "did you mean 'com'"]),
    ("kind: motion_cartesian\nrobot: ur5\nchain: arm\nwaypoints: [[0.3, 0.1, 0.3]]\ntimeout_s: .inf\n",
     InvalidBudgetError, ["timeout_s", "> 0", "inf"]),
    ("kind: motion_cartesian\nrobot: ur5\nwaypoints: [[0.3, 0.1, 0.3]]\nmethod: dlss\n", UnknownMethodError,
     ["dlss", "bounded_lm", "method"]),
    ("kind: motion_joint\nrobot: panda\nconfigurations: [[0, 0, 0, 0, 0, 0, 0]]\n", ScenarioValueError,
     ["configurations", "at least 2"]),
    ("kind: motion_joint\nrobot: panda\nconfigurations: [[0, 0], [1, 1]]\ntiming: {law: quintc}\n",
     ScenarioValueError, ["timing.law", "did you mean 'quintic'"]),
    ("kind: pincher_motion\nrobot: pincher\nmoves: [{jog: joint1, delta: 5}]\n", UnknownScenarioKeyError,
     ["moves[0].delta", "delta_deg"]),
    ("kind: bioloid_step\ngait: {zu: 0.1, zdd: 0.2}\n", UnknownScenarioKeyError, ["gait.zdd", "'zd'"]),
    ("kind: bioloid_step\nrobot: ur5\n", ScenarioValueError, ["robot", "bioloid"]),
    ("kind: bioloid_turn\nsteps: 3\n", UnknownScenarioKeyError, ["steps", "turn_deg"]),
    ("kind: bioloid_walk\nexpect: {com_margin_min_mm: 0.005}\n", ExpectationError,
     ["expect.com_margin_min_mm", "com_margin_min_m"]),
    ("kind: ur5_riveting\nrobot_params: {x: 1}\n", ScenarioValueError, ["robot_params", "ur5_riveting"]),
    ("kind: ur5_riveting\nplanners: [{name: q, planner: ours, minimum_clearence: 0.01}]\n",
     UnknownScenarioKeyError, ["planners[0].minimum_clearence", "minimum_clearance"]),
    ("kind: ur5_riveting\nexpect: {ourz: {min_score: 1}}\n", ExpectationError, ["expect.ourz", "ours"]),
    ("kind: ur5_riveting\nscene: {table: {top_zz: 0}}\n", UnknownScenarioKeyError,
     ["scene.table.top_zz", "top_z"]),
    ("kind: dance\nrobot: golem3\n", ScenarioValueError, ["kind must be", "'wholebody_ik', got 'dance'"]),
    ("robot: golem3\n", ScenarioValueError, ["kind", "wholebody_ik"]),
    ("- kind: wholebody_ik\n", ScenarioFileError, ["mapping", "list"]),
    ("# only a comment\n", ScenarioFileError, ["empty"]),
    ("~\n", ScenarioFileError, ["empty", "null"]),
    ("kind: [unclosed\n", ScenarioFileError, ["not valid YAML"]),
    ("kind: wholebody_ik\nrobot: golem3\n1: x\nphases: []\n", ScenarioValueError, ["keys must be strings"]),
    (LEGGED.replace("{frame: FL_FOOT, point:", "{frame: FL_FOOT, pont:"), UnknownScenarioKeyError,
     ["soles[0].pont", "did you mean 'point'"]),
    (LEGGED.replace("{frame: FL_FOOT, point: [0, 0, 0]}", "{frame: FL_FOOT, point: [0, 0, 0], size: [1, 1]}"),
     ScenarioValueError, ["soles[0]", "exactly one of size, corners, point", "got size, point"]),
    (LEGGED.replace("{frame: FL_FOOT, point: [0, 0, 0]}", "{frame: FL_FOOT}"), ScenarioValueError,
     ["soles[0]", "exactly one of", "got none"]),
    (LEGGED.replace("point: [0, 0, 0]}", "point: [0, 0, 0], centre: [0, 0, 0]}", 1), ScenarioValueError,
     ["soles[0].centre", "size"]),
    (LEGGED.replace("{frame: FL_FOOT, point: [0, 0, 0]}", "{frame: FL_FOOT, size: [0.2, -0.1]}"),
     ScenarioValueError, ["soles[0].size[1]", "positive"]),
    (LEGGED.replace("{frame: FR_FOOT,", "{frame: FL_FOOT,"), ScenarioValueError, ["soles[1].frame", "twice"]),
    (LEGGED.replace("methods: [qp, pink]", "methods: [qp, pnik]"), ScenarioValueError,
     ["methods[1]", "did you mean 'pink'"]),
    (LEGGED.replace("methods: [qp, pink]", "methods: [{method: placo, options: {regularisation: 1}}]"),
     InvalidOptionError, ["methods[0].options.regularisation", "did you mean 'regularization'"]),
    (LEGGED.replace("methods: [qp, pink]", "methods: [qp, {method: qp}]"), ScenarioValueError,
     ["methods[1]", "label 'qp' is used twice"]),
    (LEGGED.replace("soles:", "robot_params: {floating_base: yes please}\nsoles:"), ScenarioValueError,
     ["robot_params.floating_base", "true or false"]),
    (LEGGED.replace("soles:", "robot_params: {floating_bse: true}\nsoles:"), UnknownScenarioKeyError,
     ["robot_params.floating_bse", "did you mean 'floating_base'"]),
    (LEGGED.replace("soles:", "robot_params: {facts: 1}\nsoles:"), ScenarioValueError,
     ["robot_params.facts", "Python"]),
    (LEGGED.replace("soles:", "robot_params: {soles: {FL_FOOT: [0, 0, 0]}}\nsoles:"), ScenarioValueError,
     ["soles", "not both"]),
    (LEGGED.replace("example-robot-data:solo12", "example-robot-data:solo21"), UnknownRobotError,
     ["solo21", "did you mean 'solo12'"]),
    (BALANCE.replace("robot: bioloid", "robot: bioloid\nsoles: [{frame: r_sole, point: [0, 0, 0]}]"),
     ScenarioValueError, ["soles", "declares its own soles"]),
])
def test_hostile_files_raise_typed_errors_naming_file_and_key(tmp_path, text, error, words):
    path = write(tmp_path, text)
    with pytest.raises(error) as info:
        load_scenario(path)
    assert isinstance(info.value, WbikError)
    message = str(info.value)
    assert "bad.yaml" in message, message
    for word in words:
        assert word in message, (word, message)


def test_legged_file_soles_become_the_robots_contact_points(tmp_path):
    """size (centred on centre), corners and point entries give robot_params.soles, checked by hand."""
    text = LEGGED.replace("{frame: FR_FOOT, point: [0, 0, 0]}",
                          "{frame: FR_FOOT, size: [0.2, 0.1], centre: [0.01, 0, -0.02]}").replace(
        "{frame: HL_FOOT, point: [0, 0, 0]}", "{frame: HL_FOOT, corners: [[0.1, 0, 0], [-0.1, 0, 0]]}")
    checked = validate(load_scenario(write(tmp_path, text)), "legged.yaml")
    soles = checked["robot_params"]["soles"]
    assert soles["FL_FOOT"] == [[0, 0, 0]] and soles["HL_FOOT"] == [[0.1, 0, 0], [-0.1, 0, 0]]
    corners = np.array(sorted(map(tuple, soles["FR_FOOT"])))
    np.testing.assert_allclose(corners, [[-0.09, -0.05, -0.02], [-0.09, 0.05, -0.02], [0.11, -0.05, -0.02],
                                         [0.11, 0.05, -0.02]], atol=1e-15)
    assert [entry["label"] for entry in checked["methods"]] == ["qp", "pink"]


@pytest.mark.parametrize("change, words", [
    (("{frame: FL_FOOT,", "{frame: FL_FOT,"), ["soles[0].frame", "FL_FOT", "did you mean 'FL_FOOT'"]),
    (("contacts: [FL_FOOT, FR_FOOT, HL_FOOT]", "contacts: [FL_FOOT, FR_FOOT]"),
     ["phases[0].support", "FL_FOOT", "FR_FOOT", "no support polygon"]),
])
def test_legged_file_errors_found_when_running_name_the_key(tmp_path, change, words):
    """Frames are known once the robot is loaded; support that spans no area (two point feet) is bad
    input of the phase, not a failed solve."""
    with pytest.raises(ScenarioValueError) as info:
        run_scenario(load_scenario(write(tmp_path, LEGGED.replace(*change))))
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_unknown_key_error_lists_the_known_keys(tmp_path):
    with pytest.raises(UnknownScenarioKeyError) as info:
        load_scenario(write(tmp_path, BALANCE.replace("name: shift", "nmae: shift")))
    assert info.value.path == "phases[0].nmae"
    assert {"name", "contacts", "tasks", "margin"} <= set(info.value.known)
    assert "name, regularization, support, tasks" in str(info.value)  # the known keys, sorted


def test_file_problems(tmp_path):
    with pytest.raises(ScenarioFileError, match="is a directory"):
        load_scenario(tmp_path)
    with pytest.raises(ScenarioFileError, match="does not exist"):
        load_scenario(tmp_path / "missing.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"kind: wholebody_ik\n\xff\xfe\x00\x81")
    with pytest.raises(ScenarioFileError, match="not UTF-8") as info:
        load_scenario(binary)
    assert "binary.yaml" in str(info.value)
    empty = write(tmp_path, "", "empty.yaml")
    with pytest.raises(ScenarioFileError, match="empty"):
        load_scenario(empty)
    toml = write(tmp_path, 'kind = "bioloid_placo_walk"\nstep_length = 0.02\n', "walk.toml")
    assert load_scenario(toml)["step_length"] == 0.02


def test_missing_backend_is_a_missing_dependency(tmp_path, monkeypatch):
    import qpsolvers

    monkeypatch.setattr(qpsolvers, "available_solvers", [s for s in qpsolvers.available_solvers
                                                         if s != "quadprog"])
    with pytest.raises(MissingDependencyError, match="backend.*quadprog"):
        load_scenario(write(tmp_path, BALANCE.replace("robot: bioloid", "robot: bioloid\nbackend: quadprog")))


def test_a_changed_dict_is_checked_again_before_running():
    spec = load_scenario(TASKS / "golem3_two_grippers.yaml")
    spec["phases"][0]["tasks"][0]["targt"] = [0, 0, 1]
    with pytest.raises(UnknownScenarioKeyError, match=r"phases\[0\]\.tasks\[0\]\.targt"):
        run_scenario(spec)


def test_scenario_error_is_still_the_base_of_file_errors():
    assert issubclass(ScenarioFileError, ScenarioError) and issubclass(UnknownScenarioKeyError, ScenarioError)


def test_cli_bad_scenarios_exit_2_without_traceback(tmp_path):
    bad = write(tmp_path, BALANCE.replace("frame: pelvis", "frame: pelvis, wieght: 1"))
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    for args in (["run", str(bad)], ["run", str(binary)], ["run", str(tmp_path)],
                 ["run", str(TASKS / "motion_joint_panda.yaml"), "--backend", "osqp"]):
        out = subprocess.run([str(WBIK), *args], capture_output=True, text=True, timeout=120)
        assert out.returncode == 2, (args, out.stderr)
        assert "Traceback" not in out.stderr and out.stderr.startswith("wbik: error: "), out.stderr
    out = subprocess.run([str(WBIK), "run", str(bad)], capture_output=True, text=True, timeout=120)
    assert "phases[0].tasks[1].wieght" in out.stderr and "weight" in out.stderr
    sole = write(tmp_path, LEGGED.replace("{frame: FL_FOOT,", "{frame: FL_FOT,"), "sole.yaml")
    out = subprocess.run([str(WBIK), "run", str(sole)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    assert "soles[0].frame" in out.stderr and "did you mean 'FL_FOOT'" in out.stderr, out.stderr


def test_compared_methods_hold_a_phase_s_locked_joints(tmp_path):
    """A phase's ``lock`` is a constraint of the WholeBody every compared method solves (LockedJoints; a
    peer states it in its own terms): each answer keeps the locked joint where it started."""
    import wbik
    from wbik.scenarios import run_scenario

    locked = LEGGED.replace("    tasks:", "    lock: [FL_HAA]\n    tasks:").replace("[qp, pink]",
                                                                                  "[qp, placo, pink, mink]")
    report = run_scenario(write(tmp_path, locked, "locked.yaml"))
    robot = wbik.load("example-robot-data:solo12")
    index = robot.model.joints[robot.model.getJointId("FL_HAA")].idx_q
    phase = report["phases"][0]
    for label, figures in phase["methods"].items():
        assert figures["q"][index] == pytest.approx(robot.nominal[index], abs=1e-9), label
