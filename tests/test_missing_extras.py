"""A method whose optional library is missing: the one message naming the extra to install, from
``wbik.solver``, from the library's own import, in ``wbik methods`` and in a study's not-applicable
list. The library is made missing by a ``None`` entry in ``sys.modules`` (Python's "not importable")."""

from __future__ import annotations

import json
import sys

import pytest

import wbik
from wbik.cli import main
from wbik.solvers.method_registry import IK_METHOD_REGISTRY
from wbik.study import run_study, study_from_dict

EXTRAS = {"placo": "wbik[placo]", "pink": "wbik[pink]", "mink": "wbik[mink]", "eaik": "wbik[eaik]",
          "ik_geo": "wbik[ikgeo]", "trac_ik": "wbik[tracik]", "kdl": "python3-pykdl",
          "kdl_restarts": "python3-pykdl"}
"""Each peer method and the words of its install command (the extras of pyproject.toml)."""


def _hide(monkeypatch, method: str) -> None:
    """The method's libraries and every submodule already imported (a loaded ``eaik.IK_HP`` would be found
    without its package) made not importable."""
    for module in IK_METHOD_REGISTRY.get(method).needs.modules:
        for name in [module, *(loaded for loaded in sys.modules if loaded.startswith(module + "."))]:
            monkeypatch.setitem(sys.modules, name, None)


def test_every_peer_method_names_what_it_needs():
    declared = {name for name, method in IK_METHOD_REGISTRY.entries().items() if method.needs is not None}
    assert declared == set(EXTRAS)
    assert all(IK_METHOD_REGISTRY.get(name).missing() is None for name in EXTRAS)  # all installed here


@pytest.mark.parametrize("method", sorted(EXTRAS))
def test_a_missing_library_is_a_missing_dependency_error_naming_its_extra(monkeypatch, method):
    _hide(monkeypatch, method)
    expected = IK_METHOD_REGISTRY.get(method).missing()
    assert expected is not None and EXTRAS[method] in expected and repr(method) in expected
    with pytest.raises(wbik.MissingDependencyError) as raised:
        wbik.solver(method, "ur5", chain="arm")
    assert str(raised.value) == expected


@pytest.mark.parametrize("method", ["placo", "pink", "mink", "eaik", "ik_geo", "trac_ik", "kdl"])
def test_the_librarys_own_import_says_the_same(monkeypatch, method):
    """Past the registry's check (a factory called directly): the import itself names the extra."""
    _hide(monkeypatch, method)
    factory = IK_METHOD_REGISTRY.get(method).factory
    with pytest.raises(wbik.MissingDependencyError) as raised:
        factory(wbik.load("ur5"), "arm")
    assert EXTRAS[method] in str(raised.value) and "not installed here" in str(raised.value)


def test_wbik_methods_marks_a_missing_one(monkeypatch, capsys):
    _hide(monkeypatch, "placo")
    assert main(["methods"]) == 0
    lines = capsys.readouterr().out.splitlines()
    placo = next(index for index, line in enumerate(lines) if line.startswith("placo "))
    assert "not installed" in lines[placo + 1] and "wbik[placo]" in lines[placo + 1]
    assert not any("not installed" in line for line in lines[:placo])  # the others are installed


def test_a_study_reports_the_method_not_applicable_with_the_same_words(monkeypatch, tmp_path):
    _hide(monkeypatch, "placo")
    study = study_from_dict({"name": "extras", "robot": "ur5", "chain": "arm", "target": "pose", "poses": 2,
                             "timeout_s": 0.05, "methods": ["analytic", "placo"]})
    output = run_study(study, tmp_path / "out", backend="sequential", progress=False, log=lambda _: None)
    reasons = json.loads((output / "ur5_arm_pose" / "not_applicable.json").read_text())
    assert reasons == {"placo": IK_METHOD_REGISTRY.get("placo").missing()}


def test_methods_installed_leaves_out_a_missing_one(monkeypatch):
    everything = wbik.methods()
    assert wbik.methods(installed=True) == everything  # every library is installed here
    _hide(monkeypatch, "mink")
    assert set(wbik.methods(installed=True)) == set(everything) - {"mink"}
