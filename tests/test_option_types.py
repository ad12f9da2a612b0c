"""Every IK method's options, given a value of the wrong kind, are refused with a typed error naming the
option (generated from the methods' own signatures, so a new option is covered without editing this)."""

from __future__ import annotations

import pytest

import wbik
from wbik.errors import InvalidSettingError
from wbik.options import option_schema
from wbik.schema import Boolean, Number, Text
from wbik.solvers.method_registry import method_factory


def _wrong(node) -> list:
    """Values of the wrong kind for ``node`` (None only where it is not nullable)."""
    if isinstance(node, Boolean):
        return ["yes", 1]
    if isinstance(node, Number):
        return ["x", 2.5, True] if node.integer else ["x", True, [1.0]]
    return [3] + ([] if node.nullable else [None])


def _typed_options():
    for method in sorted(wbik.methods()):
        schema = option_schema(method_factory(method), leading=2, skip=("timeout_s", "tolerances", "seed"))
        for name, key in sorted(schema.keys.items()):
            if isinstance(key.node, Boolean | Number | Text):
                yield method, name, key.node


@pytest.fixture(scope="module")
def robot():
    return wbik.load("golem3")


@pytest.mark.parametrize("method, option, node", list(_typed_options()))
def test_a_wrong_kind_of_value_is_refused_naming_the_option(robot, method, option, node):
    for value in _wrong(node):
        with pytest.raises(InvalidSettingError, match=rf"^wbik\.solver\({method!r}\): {option} must be "):
            wbik.solver(method, robot, chain="right_arm", **{option: value})


def test_the_generated_cases_cover_every_method_with_options():
    methods = {method for method, _, _ in _typed_options()}
    assert {"bounded_lm", "dls", "qp", "kdl", "trac_ik", "placo"} <= methods
