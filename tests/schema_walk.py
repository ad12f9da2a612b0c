"""The walk over a file's keys that the hostile file tests share: every key a file gives, with the schema
node that checks it (tests/test_hostile_task_files.py, tests/test_hostile_study_files.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

from wbik.schema import Anything, ListOf, Map, Refused, Shorthand, Variants

Chooser = Callable[[object, object], object | None]
"""(node, value) -> the node that checks ``value`` where the file's own check picks one, else None."""


def rule_of(node, key):
    """The rule of ``key`` inside a mapping node (a shorthand's mapping too), or None."""
    if isinstance(node, Shorthand):
        node = node.node
    if isinstance(node, Map):
        return node.keys[key].node if key in node.keys else node.values
    return None


def key_paths(node, value, path: tuple = (), choose: Chooser | None = None) -> Iterator[tuple[tuple, object]]:
    """(path, rule) of every key the file gives, through mappings, list items and variants (each variant
    chosen as the schema chooses it, and anything ``choose`` picks); ``path`` a tuple of keys and list
    indices."""
    chosen = choose(node, value) if choose is not None else None
    if chosen is not None:
        yield from key_paths(chosen, value, path, choose)
    elif isinstance(node, Variants) and isinstance(value, dict):
        name = node.select(value)
        if name in node.variants:
            yield from key_paths(node.variants[name], value, path, choose)
    elif isinstance(node, Shorthand | Map) and isinstance(value, dict):
        for key, item in value.items():
            rule = rule_of(node, key)
            if rule is None or isinstance(rule, Refused | Anything):
                continue
            yield (*path, key), rule
            yield from key_paths(rule, item, (*path, key), choose)
    elif isinstance(node, ListOf) and isinstance(value, list):
        for index, item in enumerate(value):
            yield from key_paths(node.item, item, (*path, index), choose)


def written(path: tuple) -> str:
    """A key path as errors write it: phases[0].tasks[1].axes."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text
