"""Scenario kinds: registered explicitly, one set of defaults, typed reports, robot_params honoured.

- every module of ``KIND_MODULES`` declares its kinds in ``SCENARIO_KINDS``, each kind's schema next
  to its runner; a module that cannot be imported, declares no kinds or repeats a kind is an error
  naming it (never skipped);
- keys several kinds share default to one value (backend, CoM margin, robot_params, expect);
- a runner returns a :class:`ScenarioReport` (figures, verdict, animation);
- every kind that takes ``robot_params`` builds its robot with them (checked on the robot the
  report's animation plays, against a robot built here with the same parameters).
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np
import pytest

import wbik
from wbik.errors import MissingDependencyError
from wbik.scenarios import (
    ScenarioKind,
    ScenarioReport,
    format_report,
    load_scenario,
    register_kind,
    run_scenario,
    run_scenario_report,
)
from wbik.scenarios import kinds as registry
from wbik.scenarios.kinds import ScenarioValueError, UnknownScenarioKeyError
from wbik.scenarios.schema import Robot, common_keys, validate
from wbik.schema import Key, Map, Number, Refused

TASKS = Path(__file__).resolve().parents[1] / "tasks"
EXPECTED_KINDS = {
    "wbik.scenarios.wholebody": {"wholebody_ik"},
    "wbik.motion.scenarios": {"motion_joint", "motion_cartesian"},
    "wbik.motion.walking.scenario": {"walk"},
    "wbik.apps.pincher.scenarios": {"pincher_motion"},
    "wbik.apps.golem3.scenarios": {"golem3_approach"},
    "wbik.apps.bioloid.scenarios": {"bioloid_step", "bioloid_walk", "bioloid_turn", "bioloid_keyframes",
                                    "bioloid_placo_walk", "bioloid_half_steps", "bioloid_stairs",
                                    "bioloid_stance_sensors"},
    "wbik.apps.riveting.scenarios": {"ur5_riveting"},
}


@pytest.fixture
def fresh_registry():
    """The registry emptied, over the given module list, until the test ends (what it held is
    restored afterwards: DeclaredRegistry.isolated)."""
    with contextlib.ExitStack() as stack:
        yield lambda modules: stack.enter_context(registry.KIND_REGISTRY.isolated(modules))


# -- registration ------------------------------------------------------------------------------------
def test_each_module_registers_its_own_kinds_with_schema_and_runner_side_by_side():
    import importlib

    declaring = {module.__name__ for module in registry.KIND_REGISTRY.declaring_modules()}
    assert declaring == set(EXPECTED_KINDS)  # the core's, then the applications'
    kinds = registry.KIND_REGISTRY.entries()
    assert set(kinds) == set().union(*EXPECTED_KINDS.values())
    for module_name, names in EXPECTED_KINDS.items():
        declared = importlib.import_module(module_name).SCENARIO_KINDS
        assert {kind.name for kind in declared} == names
        for kind in declared:
            assert kinds[kind.name] is kind
            assert kind.run.__module__ == kind.schema.__module__ == module_name  # next to each other
            schema = kind.schema_map
            assert isinstance(schema, Map) and {"kind", "name", "robot", "robot_params"} <= set(schema.keys)
            assert kind.format is None or callable(kind.format)


def test_a_module_of_kinds_that_cannot_be_imported_is_an_error_naming_it(fresh_registry):
    fresh_registry([*EXPECTED_KINDS, "wbik.no_such_module"])
    for call in (registry.kind_names, lambda: validate({"kind": "bioloid_step"}, "x.yaml"),
                 lambda: run_scenario({"kind": "bioloid_step", "generators": ["faithful"]})):
        with pytest.raises(registry.ScenarioKindImportError, match="wbik.no_such_module") as info:
            call()
        assert isinstance(info.value, MissingDependencyError) and "KIND_MODULES" in str(info.value)


def test_a_module_without_kinds_or_a_kind_declared_twice_is_an_error(fresh_registry):
    fresh_registry(["wbik.scenarios.wholebody", "wbik.geometry"])
    with pytest.raises(registry.ScenarioKindError, match="wbik.geometry.*SCENARIO_KINDS"):
        registry.kind_names()
    fresh_registry(["wbik.scenarios.wholebody"])
    twin = ScenarioKind("wholebody_ik", lambda spec, progress: None, Map)
    with pytest.raises(registry.ScenarioKindError, match="'wholebody_ik'.*already registered"):
        register_kind(twin)
    with pytest.raises(ScenarioValueError, match="unknown scenario kind 'wholebody_ic'.*did you mean"):
        registry.KIND_REGISTRY.get("wholebody_ic")


def test_a_kind_registered_from_user_code_runs_with_its_schema_and_default_format(fresh_registry):
    fresh_registry(["wbik.scenarios.wholebody"])

    def run(spec, on_progress):
        report = ScenarioReport(spec["name"], spec["kind"], spec["robot"], {"count": spec["count"]})
        report.add_entry("items", {"name": "one", "expectations": [{"passed": spec["count"] > 2}]})
        return report

    def schema():
        return Map({**common_keys(robot=Key(Robot(), "pincher")), "count": Key(Number(integer=True), 3)})

    register_kind(ScenarioKind("counting", run, schema))
    report = run_scenario_report({"kind": "counting", "name": "c"})
    assert report.figures["count"] == 3 and report.passed and report.verdict == "PASSED"
    assert format_report(report) == "c (counting, pincher): PASSED"
    failed = run_scenario({"kind": "counting", "name": "c", "count": 1})
    assert failed["passed"] is False and failed["verdict"] == "FAILED"
    with pytest.raises(UnknownScenarioKeyError,
                       match=r"^c\.yaml: cont: unknown field\(s\) \[.cont.\] \(did you mean .count.\?\)"):
        validate({"kind": "counting", "cont": 1}, "c.yaml")


# -- the typed report ----------------------------------------------------------------------------------
def test_a_runner_returns_a_typed_report_with_the_animation_it_plays():
    report = run_scenario_report(TASKS / "bioloid_balance.yaml")
    assert isinstance(report, ScenarioReport)
    assert report.kind == "wholebody_ik" and report.robot == "bioloid" and report.name == "bioloid_balance"
    assert report.verdict == "PASSED" and report.passed
    phases = report.figures["phases"]
    assert len(phases) == 2 and all(p["passed"] for p in phases)
    # from the start through each phase: one sample at t = 0, then 30 per phase (wbik.scenarios.wholebody)
    assert report.animation.frames == 1 + 2 * 30
    np.testing.assert_allclose(report.animation.configurations[-1], phases[-1]["q"], atol=1e-12)
    as_json = report.as_dict()
    assert as_json["passed"] is True and as_json["verdict"] == "PASSED"
    assert as_json["animation_frames"] == 61 and as_json["phases"] is phases


def test_report_verdicts_and_the_json_round_trip():
    with pytest.raises(ValueError, match="verdict"):
        ScenarioReport("n", "k", "r", verdict="ok")
    report = ScenarioReport("n", "k", "r")
    assert report.verdict == "informational" and report.passed
    report.add_entry("moves", {"expectations": [{"passed": True}]})
    assert report.verdict == "PASSED"
    report.add_entry("moves", {"expectations": [{"passed": False}]})
    assert report.verdict == "FAILED" and not report.passed
    again = ScenarioReport.from_dict(report.as_dict())
    assert again == report
    # a JSON report that says passed: false is FAILED whatever its verdict says
    claimed = {"name": "n", "kind": "k", "passed": False, "verdict": "PASSED"}
    assert ScenarioReport.from_dict(claimed).verdict == "FAILED"


# -- one set of defaults -------------------------------------------------------------------------------
def test_one_set_of_defaults_for_the_keys_kinds_share():
    from wbik.qp.backends import DEFAULT

    kinds = registry.KIND_REGISTRY.entries()
    backends = {name: kind.schema_map.keys["backend"].default for name, kind in kinds.items()
                if "backend" in kind.schema_map.keys}
    assert set(backends) == {"wholebody_ik", "bioloid_step", "bioloid_walk", "bioloid_turn",
                             "bioloid_half_steps", "bioloid_stairs", "walk"}
    assert set(backends.values()) == {DEFAULT} and DEFAULT == "daqp"
    margins = {name: kind.schema_map.keys["margin"].default for name, kind in kinds.items()
               if "margin" in kind.schema_map.keys}
    assert len(margins) == 8 and set(margins.values()) == {0.005}
    for name, kind in kinds.items():
        params = kind.schema_map.keys["robot_params"]
        assert params.default == {} or isinstance(params.node, Refused), name
        if "expect" in kind.schema_map.keys:
            assert kind.schema_map.keys["expect"].default is None, name
    # the riveting planner of ours solves QPs too: same backend, filled in by the schema
    riveting = validate({"kind": "ur5_riveting"}, "r.yaml")
    assert [p.get("backend") for p in riveting["planners"]] == [None, DEFAULT]
    assert riveting["expect"] is None


def test_defaults_shared_across_a_file_and_its_phases():
    from wbik.qp.backends import DEFAULT

    wholebody = validate({"kind": "wholebody_ik", "robot": "bioloid", "phases": [
        {"contacts": ["r_sole", "l_sole"], "tasks": [{"type": "com", "over": "r_sole", "axes": "xy"}]}]}, "x")
    step = validate({"kind": "bioloid_step"}, "y.yaml")
    assert wholebody["backend"] == step["backend"] == DEFAULT
    assert wholebody["margin"] == step["margin"] == 0.005
    phase = wholebody["phases"][0]
    assert phase["margin"] == 0.005 and phase["support"] == ["r_sole", "l_sole"]
    assert wholebody["robot_params"] == step["robot_params"] == {}
    assert phase["expect"] is None and step["expect"] is None  # runners index every declared key


def test_defaults_are_the_ones_of_the_code_the_keys_feed():
    """Values restated from the seeds and the module docstrings, not read from the schema's code."""
    turn = validate({"kind": "bioloid_turn"}, "t")
    assert turn["turn_deg"] == 20.0 and turn["timing"] == {"speed_rpm": 40.0, "law": "quintic",
                                                            "mode": "segment", "zmp_shift_max_m": None}
    assert turn["export"]["dt"] == 0.02
    walk = validate({"kind": "bioloid_walk"}, "w")
    assert (walk["steps"], walk["turn_deg"], walk["first"], walk["rear_lift"]) == (4, 0.0, "left", 0.0)
    placo = validate({"kind": "bioloid_placo_walk"}, "p")
    assert (placo["steps"], placo["step_length"]) == (4, 0.03)
    joint = validate({"kind": "motion_joint", "robot": "panda", "configurations": [[0] * 7, [0.1] * 7]}, "j")
    assert (joint["timing"]["mode"], joint["timing"]["law"], joint["samples"]) == ("global", "quintic", 10)
    golem = validate({"kind": "golem3_approach", "robot": "golem3",
                      "grasp": {"position": [0.5, -0.2, 1.2]}}, "g")
    assert golem["samples"] == 20 and golem["method"] == "dls"


# -- robot_params reach every runner that takes them -------------------------------------------------------
PITCH = 0.30  # rad; the Bioloid's default standing pitch is 20 deg (0.349 rad)

CHEAP_BIOLOID = {
    "wholebody_ik": {"phases": [{"contacts": ["r_sole", "l_sole"],
                                 "tasks": [{"type": "com", "over": "r_sole", "axes": "xy"}]}]},
    "bioloid_step": {"generators": ["faithful"]},
    "bioloid_walk": {"steps": 1},
    "bioloid_turn": {"turn_deg": 5.0},
    "bioloid_keyframes": {"behaviours": ["right_turn_medium"]},
    "bioloid_half_steps": {"sequence": ["WalkSR1"]},
    "bioloid_stance_sensors": {},
    "bioloid_placo_walk": {"steps": 1},
    "bioloid_stairs": {"climbs": 1, "stairs": {"steps": 1}},
}


@pytest.mark.parametrize("kind", sorted(CHEAP_BIOLOID))
def test_robot_params_build_the_robot_the_runner_uses(kind):
    spec = {"kind": kind, "robot": "bioloid", "robot_params": {"pitch": PITCH}, **CHEAP_BIOLOID[kind]}
    report = run_scenario_report(spec)
    robot = report.animation.robot
    wanted, default = wbik.load("bioloid", pitch=PITCH), wbik.load("bioloid")
    assert robot.name == "bioloid" and robot.model.nq == wanted.model.nq
    np.testing.assert_allclose(robot.nominal, wanted.nominal, atol=1e-12)
    assert np.max(np.abs(robot.nominal - default.nominal)) > 1e-3  # the parameter changed the robot


@pytest.mark.parametrize("kind", ["motion_joint", "motion_cartesian"])
def test_robot_params_reach_the_motion_runners(kind):
    lengths = [1.0, 1.0, 1.0]  # the default arm is 3 + 2 + 2 long
    spec = {"kind": kind, "robot": "arm3r", "robot_params": {"lengths": lengths}}
    if kind == "motion_joint":
        spec["configurations"] = [[0.0, 0.0, 0.0], [0.3, 0.2, 0.1]]
    else:
        spec.update(waypoints=[[1.5, 1.0, 0.0]], start=[0.2, 0.4, 0.3])
    report = run_scenario_report(spec)
    robot = report.animation.robot
    q = np.array([0.3, -0.5, 0.7])
    tip = robot.chain().fk(q).translation
    np.testing.assert_allclose(tip, wbik.load("arm3r", lengths=lengths).chain().fk(q).translation, atol=1e-12)
    assert np.linalg.norm(tip - wbik.load("arm3r").chain().fk(q).translation) > 0.1
    assert math.isfinite(report.figures["moves"][0]["duration_s"])


def test_riveting_refuses_robot_params_by_name(tmp_path):
    path = tmp_path / "r.yaml"
    path.write_text("kind: ur5_riveting\nrobot_params: {x: 1}\n")
    with pytest.raises(ScenarioValueError, match="ur5_riveting does not take robot_params"):
        load_scenario(path)


def test_kinds_use_the_one_declared_registry_and_its_errors_are_registry_errors(fresh_registry, tmp_path,
                                                                                   monkeypatch):
    from wbik.registry import DeclaredRegistry, RegistryError, RegistryImportError

    assert isinstance(registry.KIND_REGISTRY, DeclaredRegistry)
    assert registry.KIND_REGISTRY.modules is registry.KIND_MODULES  # register_module appends to them
    assert issubclass(registry.ScenarioKindError, RegistryError)
    assert issubclass(registry.ScenarioKindImportError, RegistryImportError)
    fresh_registry(["wbik.scenarios.wholebody"])
    with pytest.raises(registry.ScenarioKindError, match="registered as a ScenarioKind, got function"):
        register_kind(lambda spec, progress: None)
    # a user module of kinds: added by name, with its kinds; one that repeats a kind adds nothing
    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "wbik_test_user_kinds.py").write_text(
        "from wbik.schema import Map\nfrom wbik.scenarios.kinds import ScenarioKind\n"
        "SCENARIO_KINDS = (ScenarioKind('user_a', print, Map), ScenarioKind('user_a', print, Map))\n")
    twice = "wbik_test_user_kinds declares the scenario kind.*user_a"
    with pytest.raises(registry.ScenarioKindError, match=twice):
        registry.KIND_REGISTRY.register_module("wbik_test_user_kinds")
    assert "user_a" not in registry.kind_names()
    assert "wbik_test_user_kinds" not in registry.KIND_REGISTRY.modules
