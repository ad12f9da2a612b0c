"""The study report: blocks (:mod:`wbik.study.blocks`) rendered to Markdown and to one self-contained
HTML page (figures embedded as base64 PNG); each case's section comes from its kind."""

from __future__ import annotations

import base64
import html
import json
import re
from datetime import UTC, datetime
from pathlib import Path

import wbik.study.results as store
from wbik.study.blocks import Block, budget_semantics, fmt
from wbik.study.case_kinds import case_kind, kinds_of
from wbik.study.compare import Comparison, comparison_blocks
from wbik.study.cpu_watch import STARVED_CPU_SHARE, threads_of
from wbik.study.provenance import PROVENANCE, provenance_lines
from wbik.study.spec import Study


def build_blocks(study: Study, output: Path, analyses: list[dict],
                 comparison: Comparison | None = None) -> list[Block]:
    run = store.read_json(output / "run.json", {}) or {}
    blocks = [Block("h1", f"Study {study.name}")]
    if study.description:
        blocks.append(Block("p", study.description.strip()))
    blocks.append(Block("list", items=[
        f"definition: {study.source} (fingerprint {study.fingerprint()})",
        "poses per case: " + ", ".join(f"{c.name} {study.poses_of(c)}" for c in study.cases)
        + f"; seed {study.seed}",
        f"shared FK check: position error <= {study.tolerances['position']:g} m and rotation error <= "
        f"{study.tolerances['rotation']:g} rad",
        f"default time budget {study.timeout_s:g} s per pose; start q0 = {study.start}",
        f"last run: {run.get('jobs', '?')} job(s), backend {run.get('backend', '?')}, "
        f"{fmt(run.get('seconds'))} s for {run.get('computed_tasks', '?')} chunk(s) "
        f"({fmt(run.get('total_seconds'))} s of solving over all runs of this folder); "
        f"report written {datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')}",
        *provenance_lines(store.read_json(output / PROVENANCE, {}) or {}),
    ]))
    blocks.append(Block("h2", "Methods"))
    kinds = kinds_of(study.cases)
    budget_kind = kinds[0]  # states the budgets of the methods table (the first kind in registry order)
    workers = run.get("workers", {}) or {}
    blocks.append(Block("table", header=["label", "method", "budget", "what the budget measures", "options",
                                         "note"],
                        rows=[[m.label, m.method, budget_kind.budget_text(m, study.timeout_of(m)),
                               budget_semantics(budget_kind, m, study.timeout_of(m), workers.get(m.method)),
                               json.dumps(m.options) if m.options else "", m.note] for m in study.methods]))
    if threaded := sorted({m.method for m in study.methods if threads_of(m.method) > 1}):
        blocks.append(Block("p", f"Methods with threads of their own ({', '.join(threaded)}) run after the "
                                 "others with at most cores / threads worker processes "
                                 f"({run.get('cores', '?')} cores here; the loky backend); a solve of theirs "
                                 f"is CPU-starved below {STARVED_CPU_SHARE:g} x threads x wall time of CPU "
                                 "(wbik.study.cpu_watch)."))
    blocks.extend(Block("p", note) for note in dict.fromkeys(kind.methods_note for kind in kinds) if note)
    load = run.get("load_average_before"), run.get("load_average_after")
    if any(value is not None for value in load):
        blocks.append(Block("p", f"Machine load (1/5/15-minute load averages) before the last run: "
                                 f"{load[0]}, after: {load[1]}, on {run.get('cpu_count', '?')} CPUs."))
    blocks.extend(Block("p", note) for note in dict.fromkeys(kind.study_note for kind in kinds) if note)
    if study.notes:
        blocks.append(Block("p", study.notes.strip()))
    for analysis in analyses:
        blocks.extend(case_kind(analysis["case"]).blocks(study, analysis))
    if comparison is not None:
        blocks.extend(comparison_blocks(comparison))
    return blocks


def render_markdown(blocks: list[Block], base: Path) -> str:
    lines: list[str] = []
    for block in blocks:
        if block.kind.startswith("h"):
            lines += ["#" * int(block.kind[1]) + " " + block.text, ""]
        elif block.kind == "p":
            lines += [block.text, ""]
        elif block.kind == "list":
            lines += [f"- {item}" for item in block.items] + [""]
        elif block.kind == "table":
            rows = [" | ".join(str(c).replace("|", "\\|") for c in row) for row in block.rows]
            lines += [f"| {' | '.join(map(str, block.header))} |", "|" + "---|" * len(block.header),
                      *(f"| {row} |" for row in rows), ""]
        elif block.kind == "image":
            lines += [f"![{block.text}]({block.path.relative_to(base).as_posix()})", ""]
    return "\n".join(lines)


_STYLE = """body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
.table{overflow-x:auto;margin:0.6em 0}table{border-collapse:collapse;font-size:0.85em}
td,th{border:1px solid #ccc;padding:3px 7px;text-align:left;vertical-align:top}td.number{text-align:right;
white-space:nowrap}th{background:#f0f0f0}tbody tr:nth-child(even){background:#fafafa}img{max-width:100%}
figure{margin:1em 0}figcaption{color:#555;font-size:0.9em}h2{border-bottom:1px solid #ddd;margin-top:2em}"""
_NUMBER = re.compile(r"^[-+]?(\d[\d.e+-]*|-)( ?%)?( ?\[[-\d.e+, ]+\])?$|^\[[-\d.e+, ]+\]$|^\d+/\d+$")
"""A table cell that holds a number, a count of all, an interval or '-' (right-aligned in HTML)."""


def _cell(value) -> str:
    text = str(value)
    kind = " class='number'" if _NUMBER.match(text) else ""
    return f"<td{kind}>{html.escape(text)}</td>"


def render_html(blocks: list[Block], title: str) -> str:
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_STYLE}</style></head><body>"]
    for block in blocks:
        if block.kind.startswith("h"):
            parts.append(f"<{block.kind}>{html.escape(block.text)}</{block.kind}>")
        elif block.kind == "p":
            parts.append(f"<p>{html.escape(block.text)}</p>")
        elif block.kind == "list":
            parts.append("<ul>" + "".join(f"<li>{html.escape(str(i))}</li>" for i in block.items) + "</ul>")
        elif block.kind == "table":
            head = "".join(f"<th>{html.escape(str(h))}</th>" for h in block.header)
            body = "".join("<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in block.rows)
            parts.append(f"<div class='table'><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody>"
                         "</table></div>")
        elif block.kind == "image":
            data = base64.b64encode(block.path.read_bytes()).decode()
            parts.append(f"<figure><img alt='{html.escape(block.text)}' src='data:image/png;base64,{data}'>"
                         f"<figcaption>{html.escape(block.text)}</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(study: Study, output: Path, comparison: Comparison | None = None) -> tuple[Path, Path]:
    """Analyse every case and write ``report.md`` and ``report.html`` (``comparison``'s section last)."""
    output = Path(output)
    analyses = [case_kind(case).analyse(study, case, output) for case in study.cases]
    blocks = build_blocks(study, output, analyses, comparison)
    markdown_path, html_path = output / "report.md", output / "report.html"
    store.atomic_write_text(markdown_path, render_markdown(blocks, output))
    store.atomic_write_text(html_path, render_html(blocks, f"wbik study {study.name}"))
    return markdown_path, html_path
