"""The whole-body registries (case samplers, methods): modules listed by name in the core, each module
declares what it provides; a module that fails to import or clashes is an error naming it, user code
registers its own; and the whole-body core names no seed robot."""

from __future__ import annotations

import contextlib
import re
import textwrap
import zlib
from pathlib import Path

import numpy as np
import pytest

import wbik
import wbik.wholebody
from wbik.qp.tasks import PositionTask
from wbik.registry import RegistryError, RegistryImportError
from wbik.solvers import method_registry as methods
from wbik.solvers.method import IKMethod
from wbik.solvers.qp import QPSolver
from wbik.wholebody import cases
from wbik.wholebody.cases import CASE_REGISTRY, CaseSampler, WholeBodyCase, register_sampler, sample_case
from wbik.wholebody.problem import WholeBody

SEED_ROBOTS = re.compile(r"golem|bioloid|pincher|ur5|arm3r|thesis", re.IGNORECASE)
REGISTRY_STRING = re.compile(r"[\"']wbik\.apps(\.\w+)+(:\w+)?[\"']")
"""A module of an application named by a registry string (the one way the core may name one)."""


@pytest.fixture
def modules(tmp_path, monkeypatch):
    """Write modules into an importable folder: ``modules(name=source, ...)``."""
    monkeypatch.syspath_prepend(str(tmp_path))

    def write(**sources: str) -> None:
        for name, source in sources.items():
            (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))

    return write


@pytest.fixture
def isolate():
    """``isolate(registry, modules=None)``: the registry with nothing loaded, listing ``modules``,
    until the test ends (DeclaredRegistry.isolated); returns it."""
    with contextlib.ExitStack() as stack:
        yield lambda registry, modules=None: stack.enter_context(registry.isolated(modules))


def _sampler_module(name: str) -> str:
    return f"""
        from wbik.wholebody.cases import CaseSampler
        WHOLEBODY_CASES = (CaseSampler({name!r}, "ur5", print),)
    """


# -- case samplers ----------------------------------------------------------------------------------------
def test_the_shipped_samplers_come_from_their_applications():
    samplers = CASE_REGISTRY.entries()
    assert list(samplers) == ["bioloid_com_shift", "bioloid_foot_lift", "bioloid_reach_two_feet",
                              "bioloid_reach_one_foot", "golem3_two_grippers"]
    assert {name: s.sample.__module__ for name, s in samplers.items()} == {
        **{name: "wbik.apps.bioloid.wholebody_cases" for name in list(samplers)[:4]},
        "golem3_two_grippers": "wbik.apps.golem3.wholebody_cases"}
    assert all(s.description for s in samplers.values())


def test_a_listed_sampler_module_that_fails_to_import_is_an_error_naming_it(modules, isolate):
    modules(wbik_test_broken_cases="import wbik_test_no_such_dependency  # noqa: F401\n")
    fresh = isolate(cases.CASE_REGISTRY, [*cases.CASE_MODULES, "wbik_test_broken_cases"])
    with pytest.raises(RegistryImportError, match="wbik_test_broken_cases") as error:
        sample_case("bioloid_com_shift", 1, 0)  # never skipped, even for a sampler of another module
    assert "wbik_test_no_such_dependency" in str(error.value) and "CASE_MODULES" in str(error.value)
    fresh = isolate(cases.CASE_REGISTRY, cases.CASE_MODULES)
    with pytest.raises(RegistryImportError, match="wbik_test_not_a_module"):
        cases.CASE_REGISTRY.register_module("wbik_test_not_a_module")
    assert fresh.modules == cases.CASE_MODULES  # not added
    assert "bioloid_com_shift" in CASE_REGISTRY.entries()


def test_a_module_without_samplers_or_with_a_taken_name_is_an_error_naming_it(modules, isolate):
    modules(wbik_test_no_cases="X = 1\n", wbik_test_taken=_sampler_module("bioloid_com_shift"),
            wbik_test_twice="""
                from wbik.wholebody.cases import CaseSampler
                WHOLEBODY_CASES = (CaseSampler("twice", "ur5", print), CaseSampler("twice", "ur5", print))
            """)
    for module, message in [("wbik_test_no_cases", "has no WHOLEBODY_CASES tuple of CaseSampler"),
                            ("wbik_test_taken", "'bioloid_com_shift' of wbik_test_taken is already "
                                                "registered \\(by wbik.apps.bioloid.wholebody_cases\\)"),
                            ("wbik_test_twice", "declares the whole-body case sampler\\(s\\) twice twice")]:
        isolate(cases.CASE_REGISTRY, [*cases.CASE_MODULES, module])
        with pytest.raises(RegistryError, match=message):
            CASE_REGISTRY.entries()


def test_user_code_registers_a_sampler_on_any_robot_and_gets_the_seeded_stream(isolate, tmp_path):
    """A sampler on the UR5 (no application of the core's): its stream is default_rng([seed,
    crc32(name), index]) whoever draws the case; the study runs it like a shipped one."""
    from wbik.models import load

    isolate(cases.CASE_REGISTRY, cases.CASE_MODULES)
    robot = load("ur5")
    drawn = []

    def tool_reach(rng: np.random.Generator, index: int) -> WholeBodyCase:
        q_true = robot.chain("arm").random(rng)
        drawn.append(q_true)
        target = robot.frame_placement(q_true, "tcp").translation.copy()
        problem = WholeBody(robot, [PositionTask("tcp", target, name="tcp")], limits="position",
                            name=f"tool_reach[{index}]")
        return WholeBodyCase(problem, robot.nominal.copy(), target, q_true)

    sampler = CaseSampler("tool_reach", "ur5", tool_reach, "the tool to a random reachable point")
    register_sampler(sampler)
    case = sample_case("tool_reach", 7, 3)
    expected = robot.chain("arm").random(np.random.default_rng([7, zlib.crc32(b"tool_reach"), 3]))
    assert np.array_equal(case.q_true, expected) and case.problem.name == "tool_reach[3]"
    with pytest.raises(RegistryError, match="'tool_reach' of register\\(\\) is already registered"):
        register_sampler(CaseSampler("tool_reach", "ur5", tool_reach))
    register_sampler(sampler, replace=True)
    with pytest.raises(RegistryError, match="registered as a CaseSampler"):
        register_sampler(tool_reach)
    with pytest.raises(wbik.errors.UnknownNameError, match="tool_reach"):
        sample_case("tool_rech", 7, 3)

    import csv

    from wbik.study import run_study, study_from_dict

    study = study_from_dict({"name": "user_sampler", "seed": 7, "poses": 2, "timeout_s": 0.05,
                             "cases": [{"target": "wholebody", "scenario": "tool_reach"}],
                             "methods": ["qp", "thesis_legs"]}, source="test")
    assert study.cases[0].robot == "ur5"
    output = run_study(study, tmp_path / "out", backend="sequential", progress=False,
                       log=lambda message: None)
    rows = list(csv.DictReader((output / "tool_reach" / "raw.csv").open()))
    assert [(row["method"], row["pose"]) for row in rows] == [("qp", "0"), ("qp", "1")]
    assert "does not apply to 'ur5'" in (output / "tool_reach" / "not_applicable.json").read_text()


# -- methods ----------------------------------------------------------------------------------------------
def test_the_whole_body_methods_are_in_the_one_registry_and_user_code_adds_one(isolate):
    assert {"qp", "placo", "pink", "mink", "thesis_legs"} <= set(wbik.methods())
    isolate(methods.IK_METHOD_REGISTRY)

    class Mine(QPSolver):
        name = "mine"

    methods.register_method(IKMethod("mine", Mine, "ours, renamed"))
    assert wbik.methods()["mine"] == "ours, renamed"
    from wbik.models import load

    solver = wbik.solver("mine", load("bioloid"), backend="daqp")
    assert isinstance(solver, Mine)
    bioloid = solver.robot
    target = bioloid.frame_placement(bioloid.nominal, "r_hand").translation + np.array([0.0, 0.0, 0.01])
    problem = WholeBody(bioloid, [PositionTask("r_hand", target)], contacts=["r_sole", "l_sole"])
    assert solver.solve(problem, bioloid.nominal).success  # a whole body, through the one interface
    with pytest.raises(RegistryError, match="'qp' of register\\(\\) is already registered"):
        methods.register_method(IKMethod("qp", Mine))
    with pytest.raises(RegistryError, match="the factory must be a Solver subclass or a callable"):
        IKMethod("bad", 3)
    with pytest.raises(wbik.errors.UnknownMethodError, match="mine"):
        wbik.solver("qp2", load("ur5"))


def test_a_listed_method_module_that_fails_to_import_is_an_error_naming_it(modules, isolate):
    modules(wbik_test_broken_methods="raise ImportError('libfoo is missing')\n")
    isolate(methods.IK_METHOD_REGISTRY, [*methods.METHOD_MODULES, "wbik_test_broken_methods"])
    with pytest.raises(RegistryImportError, match="wbik_test_broken_methods.*libfoo is missing"):
        wbik.methods()


# -- the core knows no seed robot ----------------------------------------------------------------------------
def test_the_whole_body_core_names_no_seed_robot():
    """wbik/wholebody/ is generic: robots, their samplers and their methods live in the applications,
    named here only by registry strings ("wbik.apps.<app>.<module>")."""
    folder = Path(wbik.wholebody.__file__).parent
    found = [f"{path.name}:{number}: {line.strip()}"
             for path in sorted(folder.glob("*.py"))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if SEED_ROBOTS.search(REGISTRY_STRING.sub("", line))]
    assert not found, found
    # the rule can fail: a robot name outside a registry string is found, the registry string is not
    assert SEED_ROBOTS.search(REGISTRY_STRING.sub("", '"wbik.apps.bioloid.cases",  # the bioloid'))
    assert not SEED_ROBOTS.search(REGISTRY_STRING.sub("", '    "wbik.apps.bioloid.thesis_legs",'))


# -- what a fresh process lacks ----------------------------------------------------------------------------
def test_entries_added_at_run_time_are_those_a_fresh_process_lacks(modules, isolate):
    """A fresh process imports the modules listed when the registry was made: entries of register()
    and of a module added by register_module() (or appended to the list later) are carried, the
    listed modules' are not, nor is a name nobody registered."""
    modules(wbik_test_user_cases=_sampler_module("user_module_sampler"),
            wbik_test_appended_cases=_sampler_module("appended_sampler"))
    fresh = isolate(cases.CASE_REGISTRY, cases.CASE_MODULES)
    mine = CaseSampler("mine", "ur5", print)
    register_sampler(mine)
    cases.CASE_REGISTRY.register_module("wbik_test_user_cases")
    fresh.modules.append("wbik_test_appended_cases")
    assert cases.CASE_REGISTRY.added_at_run_time("mine") is mine
    for name in ("user_module_sampler", "appended_sampler"):
        assert cases.CASE_REGISTRY.added_at_run_time(name) is CASE_REGISTRY.entries()[name]
    assert cases.CASE_REGISTRY.added_at_run_time("bioloid_com_shift") is None
    assert cases.CASE_REGISTRY.added_at_run_time("nobody") is None
    # a listed module's entry replaced from user code is the user's now, and carried
    replacement = CaseSampler("bioloid_com_shift", "ur5", print)
    register_sampler(replacement, replace=True)
    assert cases.CASE_REGISTRY.added_at_run_time("bioloid_com_shift") is replacement


def test_the_facade_registers_samplers_and_methods_next_to_register(isolate):
    """wbik.register_sampler / wbik.register are the registries' own functions, and what they register is
    what the one interface and the study find."""
    isolate(cases.CASE_REGISTRY)
    isolate(methods.IK_METHOD_REGISTRY)
    assert wbik.register_sampler is cases.register_sampler and wbik.CaseSampler is CaseSampler
    assert wbik.register is methods.register and wbik.IKMethod is IKMethod
    assert wbik.WholeBodyCase is WholeBodyCase
    assert {"register", "register_sampler"} <= set(wbik.__all__)

    class Facade(QPSolver):
        name = "facade_qp"

    wbik.register("facade_qp", Facade, "via the facade")
    wbik.register_sampler(wbik.CaseSampler("facade_cases", "ur5", print, "via the facade"))
    assert wbik.methods()["facade_qp"] == "via the facade"
    assert isinstance(wbik.solver("facade_qp", "ur5"), Facade)
    assert CASE_REGISTRY.entries()["facade_cases"].description == "via the facade"
    assert methods.IK_METHOD_REGISTRY.added_at_run_time("facade_qp") is not None  # to workers


def test_an_isolated_registry_gives_back_what_it_held():
    """DeclaredRegistry.isolated: inside, nothing loaded and only the given modules; the module's
    functions (bound to the registry) see that; afterwards the entries, list and origins are back."""
    before = dict(CASE_REGISTRY.entries())
    mine = CaseSampler("isolated_only", "ur5", print)
    with cases.CASE_REGISTRY.isolated([]) as isolated:
        assert isolated is cases.CASE_REGISTRY and CASE_REGISTRY.entries() == {} and isolated.modules == []
        register_sampler(mine)
        assert CASE_REGISTRY.entries() == {"isolated_only": mine}
    assert CASE_REGISTRY.entries() == before and "isolated_only" not in CASE_REGISTRY.entries()
    assert cases.CASE_REGISTRY.modules is cases.CASE_MODULES
    assert cases.CASE_REGISTRY.added_at_run_time("bioloid_com_shift") is None
