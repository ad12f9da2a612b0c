"""Hostile study files generated from the study schema: in every shipped study file, every key the file
gives (the study's, each method's, each case's with its kind's own keys, nested blocks) is replaced by a
value of the wrong type and, where the schema says one, by a wrong value of the right type (outside its
range, a word not among the allowed ones); each must be refused by ``load_study`` with a typed
:class:`StudyDefinitionError` naming the key's path, and ``wbik study FILE`` must exit 2 on a sample of
them. A new key is covered as soon as a shipped file uses it."""

from __future__ import annotations

import math
import random

import pytest
import yaml
from schema_walk import key_paths, written

from wbik.schema import Boolean, Constant, Context, Either, Interval, ListOf, Map, Number, Shorthand, Text
from wbik.study.case_kinds import kinds_of
from wbik.study.definition import (
    COMPARISONS_DIR,
    CaseEntry,
    _case_keys,
    _case_kind,
    case_schema,
    load_study,
    study_schema,
)
from wbik.study.spec import StudyDefinitionError

FILES = sorted(COMPARISONS_DIR.glob("*.yaml"))


def _wrong_values(node) -> list:
    """Values ``node`` must refuse: one of a wrong type, and wrong values of the right type where the
    node says what is allowed (a range, a set of words, a name pattern, a length)."""
    if isinstance(node, Number):
        values = [[1.0], "not a number"]
        if node.integer:
            values.append(0.5 + (node.ge or node.gt or 0))
        for bound, step in ((node.gt, 0.0), (node.ge, -1.0), (node.lt, 0.0), (node.le, 1.0)):
            if bound is not None:
                values.append(bound + step)
        if node.finite:
            values.append(math.nan)
        return values
    if isinstance(node, Text):
        values = [{"a": 1}]
        if node.choices:
            values.append("certainly-not-one-of-them")
        if node.pattern is not None:
            values.append("a name with spaces")
        return values
    if isinstance(node, Boolean):
        return ["yes", 1]
    if isinstance(node, Interval):
        return ["abc", [node.high + 1.0, node.high + 2.0], [1.0]]
    if isinstance(node, ListOf):
        return [42] + ([[]] if node.min_items else [])
    if isinstance(node, Map | Shorthand):
        return [[1, 2]]
    if isinstance(node, Either):
        return [[[1, 2]]]
    return []


def _case_kind_schema(node, value):
    """A case entry is checked against its kind's schema, as the study's check chooses it."""
    if isinstance(node, CaseEntry) and isinstance(value, dict):
        return case_schema(_case_kind(value, "", Context("test")))
    return None


def _study_key_paths(data: dict, study):
    """The key paths of a study file: the study's keys, the case given at the top level of a single-case
    study (checked as a case, paths from the top level), and the methods' options (typed by the first of
    the cases' kinds that runs the method, as the check types them)."""
    yield from key_paths(study_schema(), data, (), _case_kind_schema)
    if "cases" not in data:
        case = {key: value for key, value in data.items() if key in _case_keys() - {"name", "poses"}}
        yield from key_paths(CaseEntry(), case, (), _case_kind_schema)
    kinds = kinds_of(study.cases)
    for index, method in enumerate(study.methods):
        kind = next(kind for kind in kinds if method.method in kind.methods())
        if method.options:
            yield from key_paths(kind.method_option_schema(method.method), method.options,
                                  ("methods", index, "options"))


def _cases():
    """Each key of each shipped file, once per field: a key repeated in further list items (the same
    field of another case or method of the same kind) is left to the first."""
    for file in FILES:
        data = yaml.safe_load(file.read_text(encoding="utf-8"))
        seen = set()
        for path, rule in _study_key_paths(data, load_study(file)):
            field = tuple("[]" if isinstance(part, int) else part for part in path)
            kind = type(_case_kind(data["cases"][path[1]], "", Context("test"))).__name__ \
                if path[0] == "cases" and len(path) > 2 else ""
            if isinstance(rule, Constant) or (field, kind) in seen:
                continue
            seen.add((field, kind))
            for index, wrong in enumerate(_wrong_values(rule)):
                yield pytest.param(file.stem, path, wrong, id=f"{file.stem}-{written(path)}-{index}")


CASES = list(_cases())


def _hostile(tmp_path, name: str, path: tuple, wrong):
    data = yaml.safe_load((COMPARISONS_DIR / f"{name}.yaml").read_text(encoding="utf-8"))
    container = data
    for part in path[:-1]:
        container = container[part]
    container[path[-1]] = wrong
    file = tmp_path / f"{name}.yaml"
    file.write_text(yaml.safe_dump(data), encoding="utf-8")
    return file


@pytest.mark.parametrize("name, path, wrong", CASES)
def test_every_key_refuses_a_wrong_value_by_its_path(tmp_path, name, path, wrong):
    file = _hostile(tmp_path, name, path, wrong)
    with pytest.raises(StudyDefinitionError) as info:
        load_study(file)
    message = str(info.value)
    assert str(file) in message and written(path) in message, message


def test_the_generator_reaches_every_part_of_the_schema():
    ids = [case.id for case in CASES]
    assert len(ids) > 200
    for part in ("-methods[", ".options.", "-cases[", ".targets.", ".path.", ".success.", ".peers[",
                 "-reference.angles.", "-regression.", "-budget_curves", "-tolerances.", "-poses-"):
        assert any(part in i for i in ids), part


@pytest.mark.parametrize("name, path, wrong", random.Random(29).sample(CASES, 6))
def test_the_command_line_exits_2_naming_the_key(tmp_path, capsys, name, path, wrong):
    from wbik.cli import main

    file = _hostile(tmp_path, name, path, wrong)
    code = main(["study", str(file), "--output", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("wbik: error: ") and "Traceback" not in err, (code, err)
    assert written(path) in err, err
    assert not (tmp_path / "out").exists()


def test_a_mistyped_method_option_is_refused_before_solving(tmp_path, capsys):
    """An option of the wrong type (bounded_lm's batch_size: x) names its path at load, exit 2."""
    from wbik.cli import main

    file = tmp_path / "bad.yaml"
    file.write_text("robot: ur5\nchain: arm\nposes: 5\n"
                    "methods: [{method: bounded_lm, options: {batch_size: x}}]\n")
    with pytest.raises(StudyDefinitionError, match=r"methods\[0\]\.options\.batch_size must be an integer"):
        load_study(file)
    assert main(["study", str(file), "--output", str(tmp_path / "out")]) == 2
    assert "methods[0].options.batch_size" in capsys.readouterr().err
