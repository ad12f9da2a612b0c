"""MkDocs hook: a page holding ``<!-- notebook: notebooks/NAME.py -->`` gets that notebook's cells (a
jupytext percent script, executed by the test suite) as Markdown text and Python code blocks, so the
tutorials are the notebooks themselves, never a copy."""

from __future__ import annotations

import re
from pathlib import Path

import jupytext

_MARKER = re.compile(r"<!--\s*notebook:\s*(\S+)\s*-->")
ROOT = Path(__file__).resolve().parent.parent


def _cells_as_markdown(path: Path) -> str:
    notebook = jupytext.reads(path.read_text(encoding="utf-8"), fmt="py:percent")
    parts = []
    for cell in notebook.cells:
        source = cell.source.strip()
        if not source:
            continue
        parts.append(source if cell.cell_type == "markdown" else f"```python\n{source}\n```")
    run = f"`jupytext --to notebook {path.relative_to(ROOT)}` makes it a notebook to run."
    return "\n\n".join(parts) + f"\n\n---\n\nSource: `{path.relative_to(ROOT)}`. {run}\n"


def on_page_markdown(markdown: str, page, config, files) -> str:
    markdown = _MARKER.sub(lambda match: _cells_as_markdown(ROOT / match.group(1)), markdown)
    return _with_task_kinds(markdown)


_KINDS_MARKER = "<!-- task-kinds -->"
_NESTING = 6


def _short(value) -> str:
    text = repr(value) if not isinstance(value, str) else f'"{value}"'
    return text if len(text) <= 40 else text[:37] + "..."


def _rows(node, path: str, depth: int) -> list[tuple[str, str, str]]:
    """(key path, what it must be, default) rows of a schema node's keys, nested maps expanded."""
    from wbik.scenario_schema import NO_DEFAULT
    from wbik.scenario_schema import ListOf
    from wbik.scenario_schema import Map
    from wbik.scenario_schema import Refused
    from wbik.scenario_schema import Variants

    rows = []
    if isinstance(node, Map):
        for key, rule in node.keys.items():
            where = f"{path}.{key}" if path else key
            if isinstance(rule.node, Refused):
                rows.append((where, f"refused: {rule.node.why}", ""))
                continue
            default = ("required" if rule.required else
                       "" if rule.default is NO_DEFAULT else _short(rule.default))
            rows.append((where, rule.node.expected, default))
            if depth < _NESTING:
                rows.extend(_rows(rule.node, where, depth + 1))
    elif isinstance(node, ListOf) and depth < _NESTING:
        rows.extend(_rows(node.item, f"{path}[]", depth + 1))
    elif isinstance(node, Variants) and depth < _NESTING:
        for name, variant in node.variants.items():
            rows.extend((f"{where} ({node.tag}: {name})", what, default)
                        for where, what, default in _rows(variant, path, depth + 1))
    return rows


def _task_kinds() -> str:
    from wbik.scenarios.kinds import KIND_REGISTRY

    out = []
    for name, kind in sorted(KIND_REGISTRY.entries().items()):
        out.append(f"## `kind: {name}`\n\n{kind.summary}\n")
        out.append("| key | value | default |\n|---|---|---|")
        for where, what, default in _rows(kind.schema_map, "", 0):
            what = what.replace("|", "\\|").replace("\n", " ")
            out.append(f"| `{where}` | {what} | {default.replace('|', '/')} |")
        out.append("")
    return "\n".join(out)


def _with_task_kinds(markdown: str) -> str:
    return markdown.replace(_KINDS_MARKER, _task_kinds()) if _KINDS_MARKER in markdown else markdown
