"""The IK method registry: every method is declared by the module holding it (IK_METHODS), the core
lists the modules; user code adds methods with wbik.register."""

import sys
import types

import pytest

import wbik
from wbik.errors import UnknownMethodError
from wbik.registry import DeclaredRegistry, RegistryError, RegistryImportError
from wbik.solvers import method_registry
from wbik.solvers.base import Solver
from wbik.solvers.dls import DampedLeastSquares
from wbik.solvers.method import IKMethod
from wbik.solvers.method_registry import IK_METHOD_REGISTRY, METHOD_MODULES, register, register_method


@pytest.fixture
def isolated():
    with IK_METHOD_REGISTRY.isolated() as registry:
        yield registry


def test_every_listed_module_declares_its_methods_and_each_name_once():
    assert isinstance(IK_METHOD_REGISTRY, DeclaredRegistry) and IK_METHOD_REGISTRY.modules is METHOD_MODULES
    declared = {}
    for module in IK_METHOD_REGISTRY.declaring_modules():
        for entry in module.IK_METHODS:
            assert entry.name not in declared, f"{entry.name} declared by {declared.get(entry.name)} too"
            declared[entry.name] = module.__name__
            assert entry.description, f"{entry.name} has no description"
    added = method_registry.IK_METHOD_REGISTRY.added_at_run_time
    built_in = {name for name in wbik.methods() if added(name) is None}
    assert set(declared) == built_in  # (other tests may have added methods of their own)
    # the methods the README and the default study name are all there
    assert {"analytic", "newton", "dls", "bounded_lm", "qp", "kdl", "kdl_restarts", "trac_ik", "placo",
            "eaik", "thesis_literal", "thesis_sweep"} <= set(declared)


def test_a_user_method_is_added_replaced_on_re_registration_and_travels_as_an_entry(isolated):
    class Mine(DampedLeastSquares):
        pass

    register("mine_test", Mine, "first")
    register("mine_test", Mine, "again")  # re-running a notebook cell
    assert wbik.methods()["mine_test"] == "again"
    entry = method_registry.IK_METHOD_REGISTRY.added_at_run_time("mine_test")
    assert entry == IKMethod("mine_test", Mine, "again")
    assert method_registry.IK_METHOD_REGISTRY.added_at_run_time("dls") is None  # a fresh process has it
    assert isinstance(wbik.solver("mine_test", "arm3r"), Mine)


def test_a_built_in_method_is_not_shadowed_by_accident(isolated):
    with pytest.raises(RegistryError, match="wbik.solvers.dls"):
        register("dls", DampedLeastSquares)

    class Louder(DampedLeastSquares):
        pass

    register_method(IKMethod("dls", Louder, "on purpose"), replace=True)
    assert isinstance(wbik.solver("dls", "arm3r"), Louder)


def test_a_factory_path_is_imported_at_registration(isolated):
    register("by_path_test", "wbik.solvers.dls:DampedLeastSquares")
    assert isinstance(wbik.solver("by_path_test", "arm3r"), DampedLeastSquares)
    with pytest.raises(RegistryError, match="cannot import"):
        register("bad_path_test", "wbik.solvers.no_such_module:Solver")
    with pytest.raises(RegistryError, match="must be a Solver subclass or a callable"):
        IKMethod("not_callable", 42)


def test_listed_modules_that_fail_are_errors_naming_them(isolated, monkeypatch):
    bare = types.ModuleType("wbik_test_no_methods")
    monkeypatch.setitem(sys.modules, bare.__name__, bare)
    with IK_METHOD_REGISTRY.isolated([*METHOD_MODULES, bare.__name__]):
        with pytest.raises(RegistryError, match="wbik_test_no_methods .*IK_METHODS"):
            wbik.methods()
    with IK_METHOD_REGISTRY.isolated([*METHOD_MODULES, "wbik_test_not_importable"]):
        with pytest.raises(RegistryImportError, match="wbik_test_not_importable"):
            wbik.methods()
    twice = types.ModuleType("wbik_test_twice")
    twice.IK_METHODS = (IKMethod("dls", DampedLeastSquares),)
    monkeypatch.setitem(sys.modules, twice.__name__, twice)
    with IK_METHOD_REGISTRY.isolated([*METHOD_MODULES, twice.__name__]):
        with pytest.raises(RegistryError, match="'dls' of wbik_test_twice is already registered"):
            wbik.methods()


def test_an_unknown_method_lists_the_known_ones():
    with pytest.raises(UnknownMethodError) as info:
        wbik.solver("no_such_method", "arm3r")
    assert "bounded_lm" in str(info.value)
    assert issubclass(DampedLeastSquares, Solver)


def test_option_schemas_follow_the_class_hierarchy_as_far_as_options_are_handed_on():
    from wbik.errors import InvalidOptionError, InvalidSettingError
    from wbik.options import OPTION_ERRORS, option_schema
    from wbik.schema import Context

    class Base:
        def __init__(self, robot, chain=None, *, timeout_s=None, seed=None):
            pass

    class HandsOn(Base):
        def __init__(self, robot, chain=None, *, gain=1.0, **options):
            super().__init__(robot, chain, **options)

    class Stops(Base):
        def __init__(self, robot, chain=None, *, gain=1.0):
            super().__init__(robot, chain)

    assert option_schema(HandsOn, leading=2).accepted == {"gain", "timeout_s", "seed"}
    assert option_schema(Stops, leading=2).accepted == {"gain"}
    assert option_schema(lambda robot, chain, *, x=1: None, leading=2).accepted == {"x"}
    assert option_schema(lambda robot, chain, **anything: None, leading=2).accepted is None
    schema = option_schema(Stops, leading=2, owner="method 'm'")
    ctx = Context("wbik.solver('m')", OPTION_ERRORS)
    assert schema.check({"gain": 2}, "", ctx) == {"gain": 2}
    with pytest.raises(InvalidOptionError, match=r"^wbik\.solver\('m'\): gian: unknown option\(s\) "
                       r"\['gian'\] \(did you mean 'gain'\?\); method 'm' takes: gain$") as info:
        schema.check({"gian": 2}, "", ctx)
    assert info.value.option == "gian" and info.value.accepted == ["gain"]
    with pytest.raises(InvalidSettingError, match=r"^wbik\.solver\('m'\): gain must be a number, got 'x' "
                                                  r"\(str\)$"):
        schema.check({"gain": "x"}, "", ctx)
    # a callable's own signature decides what the option list cannot say
    with IK_METHOD_REGISTRY.isolated():
        register("needs_x_test", lambda robot, chain, *, x: DampedLeastSquares(robot, chain))
        with pytest.raises(InvalidOptionError, match="cannot take these options"):
            wbik.solver("needs_x_test", "arm3r")
        assert isinstance(wbik.solver("needs_x_test", "arm3r", x=1), DampedLeastSquares)
