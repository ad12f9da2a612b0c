"""Every IK method's options, given a value of the wrong kind, are refused with a typed error naming the
option (generated from the methods' own signatures, so a new option is covered without editing this)."""

from __future__ import annotations

import pytest

import wbik
from wbik.errors import InvalidSettingError
from wbik.registry import _expected_kind
from wbik.registry import _option_parameters
from wbik.solvers.method_registry import method_factory

WRONG = {"int": ["x", 2.5, True], "float": ["x", True, [1.0]], "bool": ["yes", 1], "str": [3, None]}


def _typed_options():
    for method in sorted(wbik.methods()):
        for name, parameter in sorted(_option_parameters(method_factory(method), leading=2).items()):
            kind = _expected_kind(parameter)
            if kind is not None and name not in ("timeout_s", "tolerances", "seed"):  # own checks
                yield method, name, kind


@pytest.fixture(scope="module")
def robot():
    return wbik.load("golem3")


@pytest.mark.parametrize("method, option, kind", list(_typed_options()))
def test_a_wrong_kind_of_value_is_refused_naming_the_option(robot, method, option, kind):
    for value in WRONG[kind]:
        if value is None and _option_parameters(method_factory(method), 2)[option].default is None:
            continue
        with pytest.raises(InvalidSettingError, match=repr(option)):
            wbik.solver(method, robot, chain="right_arm", **{option: value})


def test_the_generated_cases_cover_every_method_with_options():
    methods = {method for method, _, _ in _typed_options()}
    assert {"bounded_lm", "dls", "qp", "kdl", "trac_ik", "placo"} <= methods
