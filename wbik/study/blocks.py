"""What every case kind builds its report section from: blocks (rendered by :mod:`wbik.study.report`),
number formats, a case's rows, tables and figures, and the tables and paragraphs every section shares."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.errors import WbikError
from wbik.study.budget_curves import BudgetCurve, read_curves
from wbik.study.case_kinds import CaseKind
from wbik.study.context import chunk_count
from wbik.study.cpu_watch import STARVED_CPU_SHARE, threads_of
from wbik.study.spec import CaseSpec, MethodSpec, Study
from wbik.study.statistics import ALPHA, BATCH_CALLS, BOOTSTRAP_RESAMPLES, significance, with_holm


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
    return f"{value:.{digits}g}" if 1e-3 <= abs(value) < 1e5 else f"{value:.{digits - 1}e}"


def fmt_interval(low, high, digits: int = 3) -> str:
    """An interval for a table: "[low, high]" with :func:`fmt`'s digits, '-' when missing."""
    if low is None or high is None or not (math.isfinite(float(low)) and math.isfinite(float(high))):
        return "-"
    return f"[{fmt(low, digits)}, {fmt(high, digits)}]"


def fmt_p(value: float) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return "0" if value == 0 else f"{value:.2g}"  # 0: below the smallest double, as published tables print it


# -- per case ----------------------------------------------------------------------------------
def case_rows(study: Study, case: CaseSpec, output: Path) -> tuple[dict, dict]:
    """({label: rows} of the methods with every chunk present, {label: not-applicable message})."""
    not_applicable = store.read_json(store.case_dir(output, case.name) / "not_applicable.json", {}) or {}
    loaded = {method.label: store.load_method_rows(output, case.name, method.label, chunk_count(study, case))
              for method in study.methods if method.label not in not_applicable}
    return {label: rows for label, rows in loaded.items() if rows is not None}, not_applicable


def write_table(path: Path, table: dict[str, dict]) -> None:
    """``{label: {figure: value}}`` as a CSV with a row per method (``repr`` of numbers); none if empty."""
    if table:
        keys = list(next(iter(table.values())))
        store.write_csv(path, ["method", *keys], [[label, *(v if isinstance(v, str) else repr(v)
                                                            for v in (row[k] for k in keys))]
                                                  for label, row in table.items()])


def write_case_tables(directory: Path, summaries: dict[str, dict], tests: list[dict]) -> None:
    """A case's summary.csv (:func:`write_table`) and, with tests, its significance.csv (a row per
    Mann-Whitney test, with its Holm-adjusted p-value)."""
    write_table(directory / "summary.csv", summaries)
    if tests:
        tests = with_holm(tests)
        store.write_csv(directory / "significance.csv", list(tests[0]),
                        [[repr(v) if isinstance(v, float) else v for v in test.values()] for test in tests])


def case_analysis(kind: CaseKind, study: Study, case: CaseSpec, output: Path, rows_by_method: dict,
                  not_applicable: dict, summaries: dict, title: str, axes: list[str], angles=None,
                  more_tests: Callable[[str], list[dict]] | None = None) -> dict:
    """What every kind's analysis of a case holds, its tables and figures written: the tests against the
    baseline (``more_tests(baseline)``: a kind's own), the budget curves and :func:`case_figures`."""
    baseline = study.baseline if study.baseline in rows_by_method else None
    tests = [*significance(baseline, rows_by_method), *(more_tests(baseline) if more_tests else [])] \
        if baseline else []
    directory = store.case_dir(output, case.name)
    write_case_tables(directory, summaries, tests)
    curves = read_curves(study, case, output, rows_by_method)
    budget_kinds = {label: budget_kind(kind, study.method(label), study.timeout_of(study.method(label)))
                    for label in rows_by_method}
    images = case_figures(rows_by_method, summaries, title, directory / "figures", axes, angles, curves,
                          budget_kinds) if study.figures else {}
    return {"case": case, "rows": rows_by_method, "not_applicable": not_applicable, "summaries": summaries,
            "tests": tests, "baseline": baseline, "axes": axes, "images": images, "curves": curves,
            "budget_kinds": budget_kinds}


def case_figures(rows_by_method: dict, summaries: dict, title: str, folder: Path, error_names: list[str],
                 angles=None, curves: dict[str, BudgetCurve] | None = None,
                 budget_kinds: dict[str, str] | None = None) -> dict[str, Path]:
    """The figures of every case (none without rows), by name: solved, errors, time, budget, throughput."""
    if not rows_by_method:
        return {}
    import wbik.study.figures as figures

    images = {"solved": figures.solved_bars(summaries, title, folder / "solved.png"),
              "errors": figures.error_boxplots(rows_by_method, error_names, title, folder / "errors.png",
                                               angles),
              "error_histograms": figures.error_histograms(rows_by_method, error_names, title,
                                                           folder / "error_histograms.png", angles),
              "time": figures.time_boxplots(rows_by_method, title, folder / "time.png"),
              "time_histogram": figures.time_histogram(rows_by_method, title, folder / "time_histogram.png"),
              "time_ecdf": figures.time_ecdf(rows_by_method, title, folder / "time_ecdf.png")}
    if curves:
        images["budget"] = figures.budget_curves(curves, budget_kinds or {}, title, folder / "budget.png")
    if any(math.isfinite(s.get("throughput_poses_per_s", math.nan)) for s in summaries.values()):
        images["throughput"] = figures.throughput_bars(summaries, title, folder / "throughput.png")
    return images


# -- budgets -----------------------------------------------------------------------------------
def budget_kind(kind: CaseKind, method: MethodSpec, seconds: float) -> str:
    """How ``method`` is budgeted in a case of ``kind``: "none" (a closed form), "iterations" (our
    loops: CPU work, the same on any machine) or "wall" (a wall clock inside another library)."""
    if kind.unbudgeted(method.method):
        return "none"
    try:
        timeout_s, _ = kind.budget(method.method, seconds, method.options)
    except WbikError:
        return "wall"
    return "iterations" if timeout_s is None else "wall"


def budget_semantics(kind: CaseKind, method: MethodSpec, seconds: float, workers: int | None = None) -> str:
    """What ``method``'s budget measures, for the report's methods table."""
    kind_of_budget = budget_kind(kind, method, seconds)
    if kind_of_budget == "none":
        return "none: a fixed amount of work per call"
    if kind_of_budget == "iterations":
        return "CPU work: iterations, the same on any machine and load"
    threads = threads_of(method.method)
    if threads == 1:
        return (f"wall clock, 1 thread; a solve given < {STARVED_CPU_SHARE:g} x wall of CPU is re-run with "
                "a stretched budget")
    ran = f"; ran with {workers} worker(s)" if workers else ""
    return (f"wall clock, {threads} threads of its own: run with at most cores / {threads} workers{ran}, "
            f"a solve given < {STARVED_CPU_SHARE:g} x {threads} x wall of CPU is re-run with a stretched "
            f"budget")


def throughput_blocks(study: Study, analysis: dict) -> list[Block]:
    """The throughput of the case's methods with a batched path (their own ``solve_many``), if any."""
    summaries = {label: s for label, s in analysis["summaries"].items()
                 if math.isfinite(s.get("throughput_poses_per_s", math.nan))}
    if not summaries:
        return []
    return [Block("h3", "Throughput of batched methods"),
            Block("p", "Methods with a batched path solved the case's targets again, once every chunk was "
                       "done and with nothing else of the study running: solve_many over all of them "
                       "in one process, and split over every usable core (workers=N, after an untimed "
                       "call that forks the processes). Throughput: the case's poses / the wall time of "
                       f"the best of {BATCH_CALLS} calls each way; 'disagree': poses whose verdict "
                       "either way differs from solve's. Every other table and figure counts the per-call "
                       "solve."),
            summary_table(summaries, [
                ("poses/s, one process", "throughput_poses_per_s"),
                ("poses/s, every core", "throughput_cores_poses_per_s"),
                ("cores", "throughput_cores"),
                ("% solved (solve_many)", "throughput_percent_solved"),
                ("disagree", "throughput_disagreements")]),
            *image_blocks(analysis["images"], {
                "throughput": "Throughput of batched methods (poses/s, solve_many over the case)"})]


def budget_blocks(study: Study, analysis: dict) -> list[Block]:
    """The case's success-versus-budget table and figure, if it has curves."""
    curves = analysis.get("curves") or {}
    if not curves:
        return []
    first = next(iter(curves.values()))
    kinds = analysis.get("budget_kinds", {})
    rows = [[label, kinds.get(label, ""), *(f"{fmt(p)} {fmt_interval(lo, hi)}" for p, lo, hi
                                            in zip(curve.percent, *curve.interval(), strict=True)),
             "flat (closed form)" if curve.unbudgeted else str(int(curve.reruns.sum()))]
            for label, curve in curves.items()]
    return [Block("h3", "Success versus budget"),
            Block("p", f"% solved (Wilson 95 % interval) of the case's first {first.poses} targets, each "
                       "method solved again at every budget, which replaces the study file's timeout_s and "
                       "max_iterations (wbik.study.budget_curves). 'iterations': the iterations that cost "
                       "that long on the reference machine; 'wall': a wall clock, CPU-starved solves re-run; "
                       "'none': a closed form, its rows at every budget."),
            Block("table", header=["method", "budget", *(f"{fmt(b)} ms" for b in first.budgets_ms), "re-run"],
                  rows=rows),
            *image_blocks(analysis["images"], {"budget": "Success versus budget (95 % bands)"})]


SOLVED_COLUMNS = [("solved", lambda s: f"{s['solved']}/{s['poses']}"), ("% solved", "percent_solved"),
                  ("% solved 95 % CI", lambda s: fmt_interval(s.get("percent_solved_ci_low"),
                                                              s.get("percent_solved_ci_high")))]
"""The first columns of every case's table: solved of all, in %, and its Wilson 95 % interval."""

_CALLS = {"all": "all calls", "solved": "solved", "unsolved": "not solved"}


def time_columns(calls: str, *statistics: str) -> list[tuple[str, str]]:
    """Columns of the time per call (ms) of ``calls`` ("all", "solved", "unsolved"), one per statistic:
    ``("p95 ms (not solved)", "time_unsolved_p95_ms")``."""
    return [(f"{statistic} ms ({_CALLS[calls]})", f"time_{calls}_{statistic}_ms") for statistic in statistics]


def median_interval_column(calls: str) -> tuple[str, object]:
    """The column of the bootstrap 95 % interval of the median time of ``calls`` ("all", "solved")."""
    return (f"median ms 95 % CI ({_CALLS[calls]})",
            lambda s: fmt_interval(s.get(f"time_{calls}_median_ci_low_ms"),
                                   s.get(f"time_{calls}_median_ci_high_ms")))


TIME_COLUMNS = [*time_columns("all", "median"), median_interval_column("all"),
                *time_columns("solved", "median"), median_interval_column("solved"),
                *time_columns("solved", "p95")]
"""The median time of all calls and of the solved ones with their 95 % intervals, and the solved ones' p95."""

INTERVALS_TEXT = (f"Intervals are 95 %: Wilson's score interval for the share solved, the percentile "
                  f"bootstrap ({BOOTSTRAP_RESAMPLES} resamples, fixed seed) for median times.")
"""The sentence under a table with :data:`SOLVED_COLUMNS` and :data:`TIME_COLUMNS`."""


def summary_table(summaries: dict[str, dict], columns) -> Block:
    """A row per method: its label, then per column ``(header, key)`` ``fmt(summary[key])``, or per
    ``(header, function)`` ``function(summary)`` (text as it is, a number through ``fmt``)."""
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
    """The Holm-adjusted Mann-Whitney p-values against the baseline, a row per method (``samples``: what
    each test compares); none without tests."""
    if not analysis["tests"]:
        return []
    tests = with_holm(analysis["tests"])
    by_method: dict[str, dict] = {}
    for test in tests:
        by_method.setdefault(test["method"], {})[test["axis"]] = (fmt_p(test["p_holm"])
                                                                  + ("*" if test["significant_holm"] else ""))
    axes_tested, pairs = list(dict.fromkeys(t["axis"] for t in tests)), len(by_method)
    return [Block("h3", f"Significance against {analysis['baseline']} (Mann-Whitney U, two-sided, Holm)"),
            Block("p", f"p-values of scipy.stats.mannwhitneyu: {samples}; adjusted for the {pairs} method(s) "
                       f"compared with {analysis['baseline']} on each axis by Holm's step-down procedure "
                       f"(family-wise error {ALPHA:g}); * marks adjusted p < {ALPHA:g}. The unadjusted "
                       "p-values are in significance.csv (p_value; adjusted: p_holm)."),
            Block("table", header=["method", *axes_tested],
                  rows=[[label, *(cells.get(axis, "-") for axis in axes_tested)]
                        for label, cells in by_method.items()])]


def image_blocks(images: dict[str, Path], captions: dict[str, str]) -> list[Block]:
    """The figures among ``images`` that ``captions`` names, in its order."""
    return [Block("image", caption, path=images[key]) for key, caption in captions.items() if key in images]


def frequent_reasons(rows_by_method: dict, most: int = 3) -> list[list]:
    """[method, reason kind, count] of the ``most`` most frequent reasons for 'not solved' per method."""
    reasons = []
    for label, rows in rows_by_method.items():
        kinds = Counter(_reason_kind(str(r)) for r, ok in zip(rows["reason"], rows["success"], strict=True)
                        if not ok)
        reasons.extend([label, reason, count] for reason, count in kinds.most_common(most))
    return reasons


def reason_blocks(rows_by_method: dict, text: str, unit: str) -> list[Block]:
    """``text`` over the table of :func:`frequent_reasons` (``unit``: what is counted); none without any."""
    if not (reasons := frequent_reasons(rows_by_method)):
        return []
    return [Block("p", text), Block("table", header=["method", "reason", unit], rows=reasons)]


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
