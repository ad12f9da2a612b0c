"""The study report: tables and figures per case, our numbers beside a reference's (the study
file's ``reference:`` block), in Markdown and in one self-contained HTML page (figures embedded as
base64 PNG).

The report is assembled once as a list of blocks (headings, paragraphs, tables, images) and
rendered to both formats, so the two always say the same thing. It also writes each case's
merged ``raw.csv``, ``summary.csv`` and ``significance.csv``.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
import math
import platform
from collections import Counter
from dataclasses import dataclass
from datetime import UTC
from datetime import datetime
from pathlib import Path

import numpy as np

from wbik.errors import WbikError
from wbik.study import figures
from wbik.study import results as store
from wbik.study.context import _frozen
from wbik.study.context import case_chain
from wbik.study.context import chunk_count
from wbik.study.definition import CaseSpec
from wbik.study.definition import Study
from wbik.study.metrics import STUDY_SEQUENCE
from wbik.study.metrics import axes as case_axes
from wbik.study.reference import REFERENCE_METRICS
from wbik.study.reference import our_figures
from wbik.study.reference import same_significance
from wbik.study.reference import verdict
from wbik.study.statistics import ALPHA
from wbik.study.statistics import significance
from wbik.study.statistics import summarize


@dataclass
class Block:
    kind: str  # "h1".."h3", "p", "table", "image", "list"
    text: str = ""
    header: list | None = None
    rows: list | None = None
    path: Path | None = None
    items: list | None = None


def fmt(value, digits: int = 3) -> str:
    """A number for a table: 3 significant digits, '-' for missing."""
    if value is None:
        return "-"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return str(int(value))
    value = float(value)
    if math.isnan(value):
        return "-"
    if value == 0:
        return "0"
    if 1e-3 <= abs(value) < 1e5:
        return f"{value:.{digits}g}"
    return f"{value:.{digits - 1}e}"


def fmt_p(value: float) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return "0" if value == 0 else f"{value:.2g}"  # 0: below the smallest double, as published tables print it


# -- per case ----------------------------------------------------------------------------------
def case_rows(study: Study, case: CaseSpec, output: Path) -> tuple[dict, dict]:
    """({label: rows} of the methods with every chunk present, {label: not-applicable message})."""
    not_applicable = store.read_json(store.case_dir(output, case.name) / "not_applicable.json", {}) or {}
    rows_by_method = {}
    for method in study.methods:
        if method.label in not_applicable:
            continue
        rows = store.load_method_rows(output, case.name, method.label, chunk_count(study, case))
        if rows is not None:
            rows_by_method[method.label] = rows
    return rows_by_method, not_applicable


def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    store.atomic_write_text(path, buffer.getvalue())


def write_case_tables(directory: Path, summaries: dict[str, dict], tests: list[dict]) -> None:
    """A case's summary.csv (a row per method: every summary figure, ``repr`` of numbers) and, with
    tests, its significance.csv (a row per Mann-Whitney test)."""
    if summaries:
        keys = list(next(iter(summaries.values())))
        _write_csv(directory / "summary.csv", ["method", *keys],
                   [[label, *(s[k] if isinstance(s[k], str) else repr(s[k]) for k in keys)]
                    for label, s in summaries.items()])
    if tests:
        keys = list(tests[0])
        _write_csv(directory / "significance.csv", keys, [[repr(t[k]) if isinstance(t[k], float) else t[k]
                                                          for k in keys] for t in tests])


def case_figures(rows_by_method: dict, summaries: dict, title: str, folder: Path, error_names: list[str],
                 angles=None) -> dict[str, Path]:
    """The figures of every case (none without rows): poses solved, errors per axis of the solved
    poses (``error_names``; ``angles`` the reference's angle convention), time and its histogram."""
    if not rows_by_method:
        return {}
    return {"solved": figures.solved_bars(summaries, title, folder / "solved.png"),
            "errors": figures.error_boxplots(rows_by_method, error_names, title, folder / "errors.png",
                                             angles),
            "time": figures.time_boxplots(rows_by_method, title, folder / "time.png"),
            "time_histogram": figures.time_histogram(rows_by_method, title, folder / "time_histogram.png")}


def analyse_case(study: Study, case: CaseSpec, output: Path) -> dict:
    """Write raw.csv, summary.csv, significance.csv and the figures of one case; return the numbers."""
    if case.target == "wholebody":
        from wbik.study.wholebody import analyse_case as analyse_wholebody

        return analyse_wholebody(study, case, output)
    directory = store.case_dir(output, case.name)
    rows_by_method, not_applicable = case_rows(study, case, output)
    chain = case_chain(case.robot, _frozen(case.robot_params), case.chain, case.base, case.tip)
    store.write_raw_csv(directory / "raw.csv", rows_by_method, chain.joint_names)
    summaries = {label: summarize(rows) for label, rows in rows_by_method.items()}
    baseline = study.baseline if study.baseline in rows_by_method else None
    tests = significance(baseline, rows_by_method) if baseline else []
    write_case_tables(directory, summaries, tests)
    angles = case.reference.angles if case.reference else None
    error_names = case_axes(case.target, angles)
    images = case_figures(rows_by_method, summaries, f"{case.robot}.{chain.name} ({case.target})",
                          directory / "figures", error_names, angles)
    return {"case": case, "chain": chain, "rows": rows_by_method, "not_applicable": not_applicable,
            "summaries": summaries, "tests": tests, "baseline": baseline, "axes": error_names,
            "images": images}


def _case_blocks(study: Study, analysis: dict) -> list[Block]:
    if analysis.get("wholebody"):
        from wbik.study.wholebody import case_blocks

        return case_blocks(study, analysis)
    case: CaseSpec = analysis["case"]
    chain = analysis["chain"]
    summaries = analysis["summaries"]
    rows_by_method = analysis["rows"]
    blocks = [Block("h2", f"Case {case.name}: {case.robot}.{chain.name}, {case.target} targets"),
              Block("p", f"{study.poses_of(case)} {case.target} targets from FK of uniform random joints "
                         f"inside the limits (seed {study.seed}); chain {chain.base_frame} -> "
                         f"{chain.tip_frame}, {chain.nq} joints ({', '.join(chain.joint_names)}); "
                         f"every method starts from q0 = {study.start}.")]
    blocks.extend(status_blocks(study, analysis))
    if not summaries:
        return blocks
    blocks.append(Block("h3", "Poses solved and time"))
    blocks.append(summary_table(summaries, [
        *SOLVED_COLUMNS,
        *TIME_COLUMNS,
        *time_columns("solved", "max"),
        *time_columns("unsolved", "median", "p95", "max", "mean"),
        ("median iterations", "iterations_median"),
        ("exceptions", "raised"),
        ("re-run (CPU starved)", lambda s: s.get("rerun", 0)),
    ]))
    blocks.append(Block("p", "Times are per call of the method alone. \"All calls\" counts every pose; "
                             "\"solved\" and \"not solved\" split them by the shared FK check. "
                             "\"Re-run\" counts wall-clock solves (KDL, TRAC-IK, PlaCo) that failed "
                             "while the machine gave them less than 80 % of their budget in CPU time "
                             "and were run again with a stretched wall budget (wbik.study.runner)."))
    reasons = frequent_reasons(rows_by_method)
    if reasons:
        blocks.append(Block("p", "Most frequent reasons for 'not solved':"))
        blocks.append(Block("table", header=["method", "reason", "poses"], rows=reasons))
    blocks.append(Block("image", "Poses solved per method", path=analysis["images"]["solved"]))
    blocks.append(Block("image", "Time per pose", path=analysis["images"]["time"]))
    blocks.append(Block("image", "Histogram of time per pose", path=analysis["images"]["time_histogram"]))

    blocks.append(Block("h3", "Error per axis (solved poses)"))
    blocks.append(Block("p", "Median |error| per axis, then the maximum. x, y, z in metres (reached - "
                             "target, base axes); rot_* the rotation vector log3(R_target^T R_reached); "
                             "alpha, beta, gamma the angles of R = Rz(gamma) Ry(beta) Rx(alpha)"
                             + _reference_angles_text(case) + "; radians. Near beta = +-90 deg (gimbal "
                             "lock) a tiny rotation can show as large, opposite alpha and gamma errors; the "
                             "rotation vector has no such artefact."))
    labels = list(summaries)
    for statistic, title in (("abs_median", "median |e|"), ("abs_max", "max |e|"),
                             ("zero_fraction", "fraction exactly 0")):
        table = [[f"{title}: {label}", *(fmt(summaries[label].get(f"err_{axis}_{statistic}"))
                                         for axis in analysis["axes"])] for label in labels]
        blocks.append(Block("table", header=["method", *analysis["axes"]], rows=table))
    blocks.append(Block("image", "Error per axis", path=analysis["images"]["errors"]))

    blocks.extend(significance_blocks(analysis, "per axis on |e| of the solved poses of each method, and "
                                                "on the time of every pose"))
    blocks.extend(_reference_blocks(case, summaries, analysis["tests"]))
    return blocks


SOLVED_COLUMNS = [("solved", lambda s: f"{s['solved']}/{s['poses']}"), ("% solved", "percent_solved")]
"""The first columns of every case's table (:func:`summary_table`): solved of all, and in %."""

_CALLS = {"all": "all calls", "solved": "solved", "unsolved": "not solved"}


def time_columns(calls: str, *statistics: str) -> list[tuple[str, str]]:
    """Columns of the time per call (ms) of ``calls`` ("all", "solved" or "unsolved"), one per
    statistic of its summary ("median", "p95", "max", "mean"): ``("p95 ms (not solved)",
    "time_unsolved_p95_ms")``."""
    return [(f"{statistic} ms ({_CALLS[calls]})", f"time_{calls}_{statistic}_ms") for statistic in statistics]


TIME_COLUMNS = [*time_columns("all", "median"), *time_columns("solved", "median", "p95")]
"""The first time columns of every case's table: the median time of all calls, then the median and
95th percentile of the solved ones (ms per call)."""


def summary_table(summaries: dict[str, dict], columns) -> Block:
    """A table with a row per method: its label, then a cell per column ``(header, key)``:
    ``fmt(summary[key])``, or ``(header, function)``: ``function(summary)`` (text as it is, a number
    through ``fmt``)."""
    def cell(summary: dict, column) -> str:
        value = column(summary) if callable(column) else summary[column]
        return value if isinstance(value, str) else fmt(value)

    return Block("table", header=["method", *(header for header, _ in columns)],
                 rows=[[label, *(cell(summary, column) for _, column in columns)]
                       for label, summary in summaries.items()])


def status_blocks(study: Study, analysis: dict) -> list[Block]:
    """The methods not applicable to the case (with why), and those whose rows are incomplete."""
    blocks = []
    not_applicable, rows_by_method = analysis["not_applicable"], analysis["rows"]
    if not_applicable:
        blocks.append(Block("p", "Not applicable to this case (or could not start):"))
        blocks.append(Block("list", items=[f"{label}: {why}" for label, why in not_applicable.items()]))
    missing = [m.label for m in study.methods
               if m.label not in rows_by_method and m.label not in not_applicable]
    if missing:
        blocks.append(Block("p", f"Incomplete (run interrupted; run the study again to resume): "
                                 f"{', '.join(missing)}."))
    return blocks


def significance_blocks(analysis: dict, samples: str) -> list[Block]:
    """The Mann-Whitney p-values against the baseline, a row per method (``samples``: what each
    test compares); none without tests."""
    if not analysis["tests"]:
        return []
    by_method: dict[str, dict] = {}
    for test in analysis["tests"]:
        mark = "*" if test["significant"] else ""
        by_method.setdefault(test["method"], {})[test["axis"]] = fmt_p(test["p_value"]) + mark
    axes_tested = list(dict.fromkeys(t["axis"] for t in analysis["tests"]))
    return [Block("h3", f"Significance against {analysis['baseline']} (Mann-Whitney U, two-sided)"),
            Block("p", f"p-values of scipy.stats.mannwhitneyu: {samples}; * marks p < 0.05."),
            Block("table", header=["method", *axes_tested],
                  rows=[[label, *(cells.get(axis, "-") for axis in axes_tested)]
                        for label, cells in by_method.items()])]


def _reference_angles_text(case: CaseSpec) -> str:
    """Where the reference's angle columns come from, for the per-axis error paragraph."""
    angles = case.reference.angles if case.reference else None
    if not angles:
        return ""
    if angles.sequence == STUDY_SEQUENCE:
        return (f" (repeated under the {case.reference.name}'s names: "
                + ", ".join(f"{angles.study_angle(axis)} = {name}" for axis, name in angles.names) + ")")
    return f"; {', '.join(angles.columns)} the {case.reference.name}'s angles of {angles.describe()}"


def frequent_reasons(rows_by_method: dict, most: int = 3) -> list[list]:
    """[method, reason kind, count] of the ``most`` most frequent reasons for 'not solved' per method."""
    reasons = []
    for label, rows in rows_by_method.items():
        failed = [str(r) for r, ok in zip(rows["reason"], rows["success"], strict=True) if not ok]
        for reason, count in Counter(_reason_kind(r) for r in failed).most_common(most):
            reasons.append([label, reason, count])
    return reasons


def _reason_kind(reason: str) -> str:
    """A reason without its numbers, so that similar failures are counted together."""
    words = []
    for word in reason.split():
        stripped = word.strip(",.;:()")
        try:
            float(stripped)
            words.append("#")
        except ValueError:
            words.append(word)
    return " ".join(words)[:120] or "(no reason given)"


def _reference_blocks(case: CaseSpec, summaries: dict, tests: list[dict]) -> list[Block]:
    """Our figures and p-values beside the reference's (the case's ``reference:`` block)."""
    reference = case.reference
    if reference is None:
        return []
    name = reference.name
    blocks = [Block("h3", f"Beside the {name}")]
    if reference.source:
        blocks.append(Block("p", f"{reference.title} figures from {reference.source}."))
    table = []
    for label, metrics in reference.figures.items():
        ours = our_figures(summaries[label]) if label in summaries else {}
        for metric, value in metrics.items():
            described = REFERENCE_METRICS[metric]
            our = ours.get(metric)
            judged = verdict(metric, value, our)
            if label in summaries and (our is None or not math.isfinite(our)):
                judged = "no such poses in our run"
            table.append([label, f"{described.description} ({described.unit})", fmt(value), fmt(our), judged])
    if table:
        blocks.append(Block("table", header=["method", "metric", name, "ours", "comparison"], rows=table))
    ours = {(t["method"], t["axis"]): t for t in tests}
    rows = []
    for label, axes in reference.significance.items():
        for axis, p_value in axes.items():
            test = ours.get((label, axis))
            our_p = test["p_value"] if test else None
            rows.append([label, axis, fmt_p(p_value), fmt_p(our_p) if our_p is not None else "-",
                         same_significance(p_value, our_p)])
    if rows:
        where = f" ({reference.significance_source})" if reference.significance_source else ""
        blocks.append(Block("p", f"Mann-Whitney p-values against the baseline, the {name}'s{where} "
                                 f"beside ours; 'same verdict' compares significance at {ALPHA:g}."))
        blocks.append(Block("table", header=["method", "axis", f"{name} p", "our p", "same verdict"],
                            rows=rows))
    if reference.notes:
        blocks.append(Block("p", "Where and why we differ: " + reference.notes.strip()))
    return blocks


# -- the whole report --------------------------------------------------------------------------
def _budget_text(study: Study, method) -> str:
    """The budget a method was built with: "N iterations (~T s)" for ours, "T s wall clock" else."""
    from wbik.study.context import solver_budget

    seconds = study.timeout_of(method)
    try:
        if study.cases and all(case.target == "wholebody" for case in study.cases):
            from wbik.study.wholebody import budget as wholebody_budget

            timeout_s, options = wholebody_budget(method.method, seconds, method.options)
        else:
            timeout_s, options = solver_budget(method.method, seconds, method.options)
    except WbikError:
        return f"{seconds:g} s"
    from wbik.solvers.method_registry import method_factory

    try:
        if getattr(method_factory(method.method), "budgeted", True) is False:
            return "none (closed form)"
    except WbikError:
        pass
    if timeout_s is None:
        if "max_iterations" in method.options:
            return f"{options['max_iterations']} iterations (set in the file)"
        return f"{options['max_iterations']} iterations (~{seconds:g} s)"
    return f"{seconds:g} s wall clock"


def build_blocks(study: Study, output: Path, analyses: list[dict]) -> list[Block]:
    run = store.read_json(output / "run.json", {}) or {}
    blocks = [Block("h1", f"Study {study.name}")]
    if study.description:
        blocks.append(Block("p", study.description.strip()))
    facts = [
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
        f"machine: {platform.machine()}, Python {platform.python_version()}",
    ]
    blocks.append(Block("list", items=facts))
    blocks.append(Block("h2", "Methods"))
    blocks.append(Block("table", header=["label", "method", "budget", "options", "note"],
                        rows=[[m.label, m.method, _budget_text(study, m),
                               json.dumps(m.options) if m.options else "", m.note] for m in study.methods]))
    if not all(case.target == "wholebody" for case in study.cases):  # whole-body budgets: STUDY_NOTE
        blocks.append(Block("p", "Budgets: methods whose loop is ours (bounded_lm, dls, newton, qp) get the "
                                 "study's time budget as an iteration budget (the iterations that cost that "
                                 "long on the reference machine) and no wall clock, so their rows are the "
                                 "same on any machine and under any load. KDL, TRAC-IK and PlaCo are "
                                 "budgeted by wall-clock time inside their libraries; TRAC-IK also restarts "
                                 "from random seeds of its own, so its rows vary from run to run."))
    load = run.get("load_average_before"), run.get("load_average_after")
    if any(value is not None for value in load):
        blocks.append(Block("p", f"Machine load (1/5/15-minute load averages) before the last run: "
                                 f"{load[0]}, after: {load[1]}, on {run.get('cpu_count', '?')} CPUs."))
    if any(case.target == "wholebody" for case in study.cases):
        from wbik.study.wholebody import STUDY_NOTE

        blocks.append(Block("p", STUDY_NOTE))
    if study.notes:
        blocks.append(Block("p", study.notes.strip()))
    for analysis in analyses:
        blocks.extend(_case_blocks(study, analysis))
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
            lines.append("| " + " | ".join(str(h) for h in block.header) + " |")
            lines.append("|" + "---|" * len(block.header))
            for row in block.rows:
                lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |")
            lines.append("")
        elif block.kind == "image":
            lines += [f"![{block.text}]({block.path.relative_to(base).as_posix()})", ""]
    return "\n".join(lines)


_STYLE = """body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.6em 0;font-size:0.85em}td,th{border:1px solid #ccc;padding:3px 7px;
text-align:right}td:first-child,th:first-child{text-align:left}th{background:#f0f0f0}img{max-width:100%}
h2{border-bottom:1px solid #ddd;margin-top:2em}"""


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
            body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>"
                           for row in block.rows)
            parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        elif block.kind == "image":
            data = base64.b64encode(block.path.read_bytes()).decode()
            parts.append(f"<figure><img alt='{html.escape(block.text)}' src='data:image/png;base64,{data}'>"
                         f"<figcaption>{html.escape(block.text)}</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(study: Study, output: Path) -> tuple[Path, Path]:
    """Analyse every case and write ``report.md`` and ``report.html`` into ``output``."""
    output = Path(output)
    analyses = [analyse_case(study, case, output) for case in study.cases]
    blocks = build_blocks(study, output, analyses)
    markdown_path, html_path = output / "report.md", output / "report.html"
    store.atomic_write_text(markdown_path, render_markdown(blocks, output))
    store.atomic_write_text(html_path, render_html(blocks, f"wbik study {study.name}"))
    return markdown_path, html_path
