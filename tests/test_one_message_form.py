"""One mistake, one message form, wherever it is made: a study file, a task file, a ``wbik.solver(...)``
call and ``WholeBody.from_dict`` all check through the schema language (:mod:`wbik.schema`), so a value of
the wrong type reads ``SOURCE: PATH must be X, got V (TYPE)`` and an unknown key ``SOURCE: PATH: ...
unknown ...(s) ['KEY'] (did you mean 'GUESS'?); ...: ...``, each with the error type its callers catch."""

from __future__ import annotations

import re

import pytest
import yaml

import wbik
from wbik.errors import InvalidOptionError, InvalidSettingError
from wbik.scenarios.kinds import ScenarioValueError
from wbik.scenarios.schema import validate
from wbik.study.definition import load_study
from wbik.study.spec import StudyDefinitionError
from wbik.wholebody.problem import WholeBody

WRONG_TYPE = re.compile(r"^(?P<source>.+?): (?P<path>[\w.\[\]]+) must be (?P<what>.+), got 'x' \(str\)$")
UNKNOWN = re.compile(r"^(?P<source>.+?): (?P<where>[\w.\[\]]+): (?:(?P<path>[\w.\[\]]+) has )?unknown "
                     r"(?:field|option)\(s\) \['(?P<key>\w+)'\] \(did you mean '(?P<guess>\w+)'\?\); .+: .+$")


def _study(tmp_path, options: dict) -> str:
    file = tmp_path / "s.yaml"
    file.write_text(yaml.safe_dump({"robot": "ur5", "chain": "arm", "poses": 5,
                                    "methods": [{"method": "qp", "options": options}]}))
    with pytest.raises(StudyDefinitionError) as info:
        load_study(file)
    return str(info.value).replace(str(file), "s.yaml")


def _task_file(options: dict, error: type[Exception]) -> str:
    spec = {"kind": "wholebody_ik", "robot": "bioloid", "methods": [{"method": "qp", "options": options}],
            "phases": [{"contacts": ["r_sole", "l_sole"], "tasks": [{"type": "com", "over": "r_sole"}]}]}
    with pytest.raises(error) as info:
        validate(spec, "t.yaml")
    return str(info.value)


def _solver(options: dict, error: type[Exception]) -> str:
    with pytest.raises(error) as info:
        wbik.solver("qp", "ur5", chain="arm", **options)
    return str(info.value)


def _from_dict(data: dict) -> str:
    with pytest.raises(InvalidSettingError) as info:
        WholeBody.from_dict(wbik.load("bioloid"), {"tasks": [{"type": "com", "over": "r_sole"}], **data})
    return str(info.value)


def test_a_value_of_the_wrong_type_reads_the_same_everywhere(tmp_path):
    option = "methods[0].options.lm_damping"
    messages = {("s.yaml", option): _study(tmp_path, {"lm_damping": "x"}),
                ("t.yaml", option): _task_file({"lm_damping": "x"}, ScenarioValueError),
                ("wbik.solver('qp')", "lm_damping"): _solver({"lm_damping": "x"}, InvalidSettingError),
                ("WholeBody.from_dict", "margin"): _from_dict({"margin": "x"})}
    for (source, path), message in messages.items():
        match = WRONG_TYPE.match(message)
        assert match and match["source"] == source and match["path"] == path, message
    whats = {WRONG_TYPE.match(message)["what"] for (_, path), message in messages.items() if path != "margin"}
    assert whats == {"a number"}, whats  # the same option, the same node, the same words


def test_an_unknown_key_reads_the_same_everywhere_with_a_guess(tmp_path):
    option = "methods[0].options.lm_dampng"
    messages = {("s.yaml", option): _study(tmp_path, {"lm_dampng": 1.0}),
                ("t.yaml", option): _task_file({"lm_dampng": 1.0}, InvalidOptionError),
                ("wbik.solver('qp')", "lm_dampng"): _solver({"lm_dampng": 1.0}, InvalidOptionError),
                ("WholeBody.from_dict", "marign"): _from_dict({"marign": 0.01})}
    for (source, where), message in messages.items():
        match = UNKNOWN.match(message)
        assert match and (match["source"], match["where"]) == (source, where), message
        assert match["key"] == where.rsplit(".", 1)[-1], message
        assert match["guess"] == {"lm_dampng": "lm_damping", "marign": "margin"}[match["key"]], message
