"""The exact wording of check_schema's refusals of unknown method options (the option schema's words:
the path, a "did you mean" guess, what the method takes) and robot parameters."""

from __future__ import annotations

import pytest

from wbik.study.definition import check_schema
from wbik.study.spec import CaseSpec, MethodSpec, StudyDefinitionError


def test_an_unknown_method_option_is_named_with_the_method_s_own_options():
    methods = [MethodSpec("fast", "dls", {"dampin": 0.1, "gian": 1})]
    with pytest.raises(StudyDefinitionError) as info:
        check_schema(methods, [CaseSpec("c", "ur5")], "s.yaml")
    assert str(info.value) == ("s.yaml: methods[0].options.dampin, methods[0].options.gian: "
                               "methods[0].options has unknown option(s) ['dampin', 'gian'] (did you mean "
                               "'damping' for 'dampin'?); method 'dls' (fast) takes: damping, max_iterations")


def test_an_unknown_whole_body_option_lists_the_method_s_options_without_the_study_s_settings():
    methods = [MethodSpec("p", "pink", {"solver": "x"})]
    with pytest.raises(StudyDefinitionError) as info:
        check_schema(methods, [CaseSpec("c", "bioloid", target="wholebody", scenario="any")], "s.yaml")
    assert str(info.value) == ("s.yaml: methods[0].options.solver: methods[0].options has unknown option(s) "
                               "['solver'] (did you mean 'qp_solver'?); method 'pink' (p) takes: damping, "
                               "max_iterations, qp_solver")


def test_an_unknown_robot_parameter_is_named_with_the_robot_s_parameters():
    cases = [CaseSpec("c", "bioloid", robot_params={"lenght": 1})]
    with pytest.raises(StudyDefinitionError) as info:
        check_schema([], cases, "s.yaml")
    assert str(info.value) == ("s.yaml: case 'c': robot_params has unknown key(s) ['lenght'] for robot "
                               "'bioloid'; its parameters: pitch, tool_length")


def test_a_robot_without_parameters_says_none():
    with pytest.raises(StudyDefinitionError, match=r"for robot 'ur5'; its parameters: \(none\)$"):
        check_schema([], [CaseSpec("c", "ur5", robot_params={"x": 1})], "s.yaml")


def test_known_options_and_parameters_pass():
    check_schema([MethodSpec("d", "dls", {"damping": 0.1, "seed": 3})],
                 [CaseSpec("c", "bioloid", robot_params={"pitch": 0.0})], "s.yaml")
