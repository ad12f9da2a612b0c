"""The regression gate: a study's run beside an earlier run of it (``wbik study FILE --compare-to
OLD``), per case and method, with a verdict; the command exits 1 when a method regressed.

For each case and method of this run that OLD has complete rows of (its chunk files), both runs'
figures are computed from their rows the same way (:mod:`wbik.study.statistics`): the share solved
p with its Wilson 95 % interval [p-, p+] and the median time of all calls m (ms) with its bootstrap
95 % interval [m-, m+]. The study file's ``regression:`` block sets the rule
(:class:`wbik.study.definition.RegressionRule`; default ``{success_drop: ci, time_rise: 1.2}``):

- success regressed, ``success_drop: ci``: p+_new < p-_old (the two 95 % intervals are disjoint, the
  new one below); ``success_drop: d`` (percentage points): p_new < p_old - d;
- time regressed, ``time_rise: r``: m-_new > r x m+_old (even the new median's most favourable
  reading is more than r times the old one's least favourable); ``time_rise: ci`` is r = 1,
  ``time_rise: off`` gates no time.

A method is *regressed* when either holds. Methods only one of the runs has, and cases OLD lacks,
are listed and never regressed. Times are only comparable between runs on the same machine under
the same load; success is comparable anywhere (our iteration-budgeted methods give the same rows on
any machine).

Written: ``comparison.csv`` in this run's folder (a row per case and method) and the report's
"Compared with" section (:func:`comparison_blocks`).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import wbik.study.results as store
from wbik.errors import UsageError
from wbik.study.blocks import Block
from wbik.study.blocks import case_rows
from wbik.study.blocks import fmt
from wbik.study.blocks import fmt_interval
from wbik.study.definition import SUCCESS_DROP_CI
from wbik.study.statistics import bootstrap_median_interval
from wbik.study.statistics import wilson_interval

if TYPE_CHECKING:
    from wbik.study.definition import RegressionRule
    from wbik.study.definition import Study


@dataclass(frozen=True)
class RunFigures:
    """One method's figures in one run: poses, solved, % solved and its Wilson 95 % interval, the
    median time of all calls (ms) and its bootstrap 95 % interval."""

    poses: int
    solved: int
    percent: float
    percent_low: float
    percent_high: float
    median_ms: float
    median_low_ms: float
    median_high_ms: float

    @classmethod
    def of_rows(cls, rows: dict[str, np.ndarray]) -> RunFigures:
        success = rows["success"].astype(bool)
        count, solved = int(success.size), int(success.sum())
        low, high = wilson_interval(solved, count)
        times = rows["time_s"] * 1e3
        finite = times[np.isfinite(times)]
        median = float(np.median(finite)) if finite.size else math.nan
        median_low, median_high = bootstrap_median_interval(times)
        return cls(count, solved, 100.0 * solved / count if count else math.nan, 100.0 * low, 100.0 * high,
                   median, median_low, median_high)


@dataclass(frozen=True)
class MethodComparison:
    """One (case, method): its figures in OLD and in this run, and the verdict."""

    case: str
    label: str
    old: RunFigures | None
    new: RunFigures | None
    success_regressed: bool = False
    time_regressed: bool = False
    verdict: str = ""

    @property
    def regressed(self) -> bool:
        return self.success_regressed or self.time_regressed


@dataclass(frozen=True)
class Comparison:
    """This run against OLD under ``rule``: a :class:`MethodComparison` per case and method."""

    old: Path
    rule: RegressionRule
    methods: list[MethodComparison]
    notes: list[str]

    @property
    def regressions(self) -> list[MethodComparison]:
        return [method for method in self.methods if method.regressed]


def success_regressed(old: RunFigures, new: RunFigures, rule: RegressionRule) -> bool:
    """Whether the share solved dropped under ``rule.success_drop`` (see the module docstring)."""
    if rule.success_drop == SUCCESS_DROP_CI:
        return new.percent_high < old.percent_low
    return new.percent < old.percent - float(rule.success_drop)


def time_regressed(old: RunFigures, new: RunFigures, rule: RegressionRule) -> bool:
    """Whether the median time rose under ``rule.time_rise`` (see the module docstring)."""
    if rule.time_rise is None or not (math.isfinite(new.median_low_ms) and math.isfinite(old.median_high_ms)):
        return False
    return new.median_low_ms > rule.time_rise * old.median_high_ms


def judge(case: str, label: str, old: RunFigures | None, new: RunFigures | None,
          rule: RegressionRule) -> MethodComparison:
    """The comparison of one (case, method) and its verdict in words."""
    if old is None or new is None:
        verdict = "not in OLD" if old is None else "not in this run"
        return MethodComparison(case, label, old, new, verdict=verdict)
    success = success_regressed(old, new, rule)
    slower = time_regressed(old, new, rule)
    words = []
    if success:
        words.append("REGRESSION: success dropped")
    if slower:
        words.append(f"REGRESSION: median time rose beyond x{rule.time_rise:g}")
    if not words:
        if new.percent_low > old.percent_high:
            words.append("better success")
        if rule.time_rise is not None and new.median_high_ms * rule.time_rise < old.median_low_ms:
            words.append("faster")
        words = words or ["same within the intervals"]
    return MethodComparison(case, label, old, new, success, slower, "; ".join(words))


def _old_study(old: Path) -> dict:
    record = store.read_json(old / "study.json")
    if record is None:
        raise UsageError(f"--compare-to {str(old)!r} holds no results of a study (no study.json): pass the "
                         "output folder of an earlier 'wbik study' run")
    return record


def old_method_rows(old: Path, record: dict, case_name: str, label: str) -> dict[str, np.ndarray] | None:
    """The rows of method ``label`` on case ``case_name`` in the run folder ``old`` (``record``: its
    study.json), None unless every chunk of it is there."""
    study = record.get("study", {})
    case = next((c for c in study.get("cases", []) if c.get("name") == case_name), None)
    if case is None:
        return None
    poses = case.get("poses") or study.get("poses")
    chunk_size = study.get("chunk_size")
    if not poses or not chunk_size:
        return None
    return store.load_method_rows(old, case_name, label, -(-int(poses) // int(chunk_size)))


def compare_runs(study: Study, output: Path, old: Path) -> Comparison:
    """This run (``output``) of ``study`` against the run folder ``old`` under the study's
    ``regression:`` rule; writes ``comparison.csv`` into ``output``."""
    old, output = Path(old), Path(output)
    if old.resolve() == output.resolve():
        raise UsageError(f"--compare-to {str(old)!r} is this run's own folder: pass the folder of an "
                         "earlier run")
    record = _old_study(old)
    notes = []
    if record.get("fingerprint") != study.fingerprint():
        notes.append(f"OLD holds a study with other cases, poses, seed, start, chunk size or tolerances "
                     f"(fingerprint {record.get('fingerprint')} != {study.fingerprint()}): its targets are "
                     "not this run's")
    methods: list[MethodComparison] = []
    for case in study.cases:
        rows_by_method, _ = case_rows(study, case, output)
        old_labels = []
        if (old / case.name).is_dir():
            old_labels = sorted(path.name for path in (old / case.name / "chunks").glob("*") if path.is_dir())
        else:
            notes.append(f"OLD has no case {case.name!r}")
        for label, rows in rows_by_method.items():
            old_rows = old_method_rows(old, record, case.name, label)
            methods.append(judge(case.name, label, None if old_rows is None else RunFigures.of_rows(old_rows),
                                 RunFigures.of_rows(rows), study.regression))
        for label in old_labels:
            if label not in rows_by_method:
                old_rows = old_method_rows(old, record, case.name, label)
                if old_rows is not None:
                    methods.append(judge(case.name, label, RunFigures.of_rows(old_rows), None,
                                         study.regression))
    comparison = Comparison(old, study.regression, methods, notes)
    _write_csv(output / "comparison.csv", comparison)
    return comparison


def rule_text(rule: RegressionRule) -> str:
    """The rule in words."""
    if rule.success_drop == SUCCESS_DROP_CI:
        success = "its % solved interval lies wholly below OLD's (95 % Wilson intervals disjoint)"
    else:
        success = f"its % solved is more than {rule.success_drop:g} points below OLD's"
    if rule.time_rise is None:
        time = "times are not gated (time_rise: off)"
    else:
        time = (f"or the lower end of its median time's 95 % bootstrap interval exceeds {rule.time_rise:g} x "
                "the upper end of OLD's")
    return f"A method regressed when {success}, {time}."


def _figures_cells(figures: RunFigures | None) -> list[str]:
    if figures is None:
        return ["-", "-", "-", "-"]
    return [fmt(figures.percent), fmt_interval(figures.percent_low, figures.percent_high),
            fmt(figures.median_ms), fmt_interval(figures.median_low_ms, figures.median_high_ms)]


def comparison_blocks(comparison: Comparison) -> list[Block]:
    """The report's section: the rule, then a row per case and method, OLD beside this run."""
    regressions = comparison.regressions
    blocks = [Block("h2", f"Compared with {comparison.old}"),
              Block("p", rule_text(comparison.rule)
                    + " (the study file's regression: block; wbik.study.compare) "
                    + (f"{len(regressions)} regression(s): "
                       + ", ".join(f"{m.case}/{m.label}" for m in regressions) + "." if regressions
                       else "No regression."))]
    blocks.extend(Block("p", note + ".") for note in comparison.notes)
    header = ["case", "method", "% solved OLD", "95 % CI OLD", "median ms OLD", "95 % CI OLD",
              "% solved", "95 % CI", "median ms", "95 % CI", "verdict"]
    blocks.append(Block("table", header=header, rows=[
        [m.case, m.label, *_figures_cells(m.old), *_figures_cells(m.new), m.verdict]
        for m in comparison.methods]))
    return blocks


def summary_lines(comparison: Comparison) -> list[str]:
    """The comparison for a terminal: a line per case and method, regressions marked."""
    lines = [f"compared with {comparison.old}: {len(comparison.regressions)} regression(s); "
             + rule_text(comparison.rule)]
    lines.extend(f"  note: {note}" for note in comparison.notes)
    for m in comparison.methods:
        old, new = m.old, m.new
        if old is None or new is None:
            lines.append(f"  {m.case} / {m.label}: {m.verdict}")
            continue
        lines.append(f"  {m.case} / {m.label}: % solved {old.percent:.1f} "
                     f"[{old.percent_low:.1f}, {old.percent_high:.1f}] -> {new.percent:.1f} "
                     f"[{new.percent_low:.1f}, {new.percent_high:.1f}]; median ms {fmt(old.median_ms)} "
                     f"{fmt_interval(old.median_low_ms, old.median_high_ms)} -> {fmt(new.median_ms)} "
                     f"{fmt_interval(new.median_low_ms, new.median_high_ms)}: {m.verdict}")
    return lines


def _write_csv(path: Path, comparison: Comparison) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    fields = ["poses", "solved", "percent", "percent_low", "percent_high", "median_ms", "median_low_ms",
              "median_high_ms"]
    writer.writerow(["case", "method", *(f"old_{f}" for f in fields), *(f"new_{f}" for f in fields),
                     "success_regressed", "time_regressed", "verdict"])
    for m in comparison.methods:
        cells = []
        for figures in (m.old, m.new):
            cells.extend([""] * len(fields) if figures is None
                         else [repr(getattr(figures, f)) for f in fields])
        writer.writerow([m.case, m.label, *cells, int(m.success_regressed), int(m.time_regressed), m.verdict])
    store.atomic_write_text(path, buffer.getvalue())
