"""MkDocs hook: a page holding ``<!-- notebook: notebooks/NAME.py -->`` gets that notebook's cells (a
jupytext percent script, executed by the test suite) as Markdown text and Python code blocks, so the
tutorials are the notebooks themselves, never a copy; ``<!-- task-kinds -->`` and ``<!-- study-keys -->``
become the key tables of task files and study files, read from their schemas (:mod:`wbik.schema`)."""

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
_STUDY_MARKER = "<!-- study-keys -->"


def _table(rows) -> list[str]:
    """A Markdown table of :func:`wbik.schema.key_rows` rows."""
    out = ["| key | value | default |", "|---|---|---|"]
    for where, what, default, doc in rows:
        what = (what + (f" ({doc})" if doc else "")).replace("|", "\\|").replace("\n", " ")
        out.append(f"| `{where}` | {what} | {default.replace('|', '/')} |")
    return out


def _task_kinds() -> str:
    from wbik.scenarios.kinds import KIND_REGISTRY
    from wbik.schema import key_rows

    out = []
    for name, kind in sorted(KIND_REGISTRY.entries().items()):
        out.append(f"## `kind: {name}`\n\n{kind.summary}\n")
        rows = key_rows(kind.schema_map)
        out.extend(_table((where, what, default, "") for where, what, default, _ in rows))
        out.append("")
    return "\n".join(out)


def _study_keys() -> str:
    """The study file's keys, its methods' and each case kind's, from the study schema."""
    from wbik.schema import Map
    from wbik.schema import key_rows
    from wbik.study.case_kinds import case_kinds
    from wbik.study.definition import _common_case_keys
    from wbik.study.definition import case_schema
    from wbik.study.definition import method_schema
    from wbik.study.definition import study_schema

    study = [row for row in key_rows(study_schema(), nesting=1) if "single-case" not in row[3]
             and not row[0].startswith(("cases", "methods"))]
    out = ["### The study", "", *_table(study), "", "### `methods[]`", "",
           *_table(key_rows(method_schema(), "methods[]")), "", "### `cases[]`: every case", "",
           *_table(key_rows(Map(_common_case_keys()), "cases[]")), ""]
    common = set(_common_case_keys())
    for name, kind in case_kinds().items():
        rows = [row for row in key_rows(case_schema(kind), "cases[]") if row[0].split(".")[1] not in common]
        if rows:
            out += [f"### `cases[]` of `target: {name}`", "", *_table(rows), ""]
    return "\n".join(out)


def _with_task_kinds(markdown: str) -> str:
    if _KINDS_MARKER in markdown:
        markdown = markdown.replace(_KINDS_MARKER, _task_kinds())
    if _STUDY_MARKER in markdown:
        markdown = markdown.replace(_STUDY_MARKER, _study_keys())
    return markdown
