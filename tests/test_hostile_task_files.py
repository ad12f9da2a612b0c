"""Hostile task files generated from the kinds' schemas: in every shipped task file, every key the file
gives is replaced by a value of the wrong type and, where the schema can say one, by a wrong value of the
right type; each must be refused by the schema check with a typed error that names the key's path (the
CLI's exit 2), never reach a runner. A new key is covered as soon as a shipped file uses it."""

from __future__ import annotations

import math

import pytest
import yaml
from schema_walk import key_paths, written

from wbik.data import shipped_tasks
from wbik.errors import WbikError
from wbik.qp.task_entries import AXES
from wbik.scenarios.kinds import KIND_REGISTRY
from wbik.scenarios.schema import validate
from wbik.schema import Boolean, Either, ListOf, Map, Number, Text, Variants, Vector


def _wrong_values(node) -> list:
    """Values ``node`` must refuse: one of a wrong type, and wrong values of the right type where the
    node says what is allowed (a range, a set of words, a subset of axes, a length)."""
    if isinstance(node, Number):
        values = ["not a number", [1.0]]
        if node.integer:
            values.append(0.5 + (node.ge or node.gt or 0))
        for bound, step in ((node.gt, 0.0), (node.ge, -1.0), (node.le, 1.0)):
            if bound is not None:
                values.append(bound + step)
        values.append(math.nan)
        return values
    if node is AXES:
        return [3, "qq", "xx", ""]
    if isinstance(node, Text):
        choices = node.choices
        return [{"a": 1}] + (["certainly-not-one-of-them"] if choices else [])
    if isinstance(node, Boolean):
        return ["yes", 1]
    if isinstance(node, Vector):
        return ["abc", [], ["a"] * (node.size or 1)] + ([[1.0] * (node.size + 1)] if node.size else [])
    if isinstance(node, ListOf):
        return [42] + ([[]] if node.min_items else [])
    if isinstance(node, Map | Variants):
        return [[1, 2]]
    return []


def _cases():
    for name, file in shipped_tasks().items():
        spec = yaml.safe_load(file.read_text(encoding="utf-8"))
        schema = KIND_REGISTRY.get(spec["kind"]).schema_map
        for path, rule in key_paths(schema, spec):
            if isinstance(rule, Either):
                continue  # which option a value takes is the node's own business
            for index, wrong in enumerate(_wrong_values(rule)):
                yield pytest.param(name, path, wrong, id=f"{name}-{written(path)}-{index}")


def _refused_naming(spec: dict, source: str, path_words: str) -> None:
    with pytest.raises(WbikError) as info:
        validate(spec, source)
    assert path_words in str(info.value), str(info.value)


@pytest.mark.parametrize("name, path, wrong", list(_cases()))
def test_every_key_refuses_a_wrong_value_by_its_path(name, path, wrong):
    spec = yaml.safe_load(shipped_tasks()[name].read_text(encoding="utf-8"))
    container = spec
    for part in path[:-1]:
        container = container[part]
    container[path[-1]] = wrong
    _refused_naming(spec, f"{name}.yaml", written(path))


def test_the_generator_reaches_the_leaks_it_is_for():
    """The com task's axes (a free string before: 'qq' reached the QP and exited 3) is generated."""
    ids = [case.id for case in _cases()]
    assert len(ids) > 300
    assert any(".axes-" in i and "tasks[" in i for i in ids), "task entries inside phases are reached"
