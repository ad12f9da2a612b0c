"""The regression gate (``wbik study FILE -o NEW --compare-to OLD``): a run beside an earlier run on the
same targets (``targets.json``), paired target by target and judged by the study's ``regression:`` rule
(:func:`rule_text`; docs/guide/studies.md, "The regression gate")."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

import wbik.study.results as store
from wbik.errors import UsageError
from wbik.study.blocks import Block, case_rows, fmt, fmt_interval, fmt_p
from wbik.study.regression_rule import RegressionRule
from wbik.study.spec import Study
from wbik.study.statistics import bootstrap_median_interval

TARGETS_RECORD = "targets.json"
SETTINGS = ("seed", "start", "tolerances", "chunk_size", "timeout_s")
"""The study's settings that shape every row (a case's own are in its definition)."""
DETERMINISTIC = ("none", "iterations")
"""Budgets whose rows are the same on any machine: a closed form's, iterations (``method.json``)."""
LISTED_POSES = 20
"""Pose ids a message lists at most (comparison.csv has them all)."""


def targets_digest(path: Path) -> str:
    """A hash of a case's saved targets (every array of its ``poses.npz``: targets, starts, ...)."""
    digest = hashlib.sha256()
    with np.load(path, allow_pickle=False) as data:
        for key in sorted(data.files):
            array = np.ascontiguousarray(data[key])
            digest.update(f"{key} {array.dtype.str} {array.shape}".encode())
            digest.update(array.tobytes())
    return digest.hexdigest()[:16]


def targets_record(study: Study, output: Path | None = None) -> dict:
    """What shapes the rows of ``study``'s run: its settings (:data:`SETTINGS`), each case's definition and,
    with ``output``, the hash of its saved targets."""
    cases = {}
    for case, data in zip(study.cases, study.row_settings()["cases"], strict=True):
        data["poses"] = study.poses_of(case)
        cases[case.name] = {"definition": json.loads(json.dumps(data, default=str))}  # as read back
        if output is not None:
            cases[case.name]["targets"] = targets_digest(store.case_dir(output, case.name) / "poses.npz")
    settings = json.loads(json.dumps({key: getattr(study, key) for key in SETTINGS}))
    return {"settings": settings, "cases": cases}


def differences(old: dict, new: dict) -> list[str]:
    """What differs between two runs' :func:`targets_record` (settings, and the cases both have)."""
    settings = [f"{key}: {old['settings'].get(key)!r} in OLD, {new['settings'].get(key)!r} here"
                for key in SETTINGS if old["settings"].get(key) != new["settings"].get(key)]
    found = list(settings)
    for name in new["cases"].keys() & old["cases"].keys():
        before, now = old["cases"][name], new["cases"][name]
        keys = sorted(key for key in before["definition"].keys() | now["definition"].keys()
                      if before["definition"].get(key) != now["definition"].get(key))
        found.extend(f"case {name}: {key} {before['definition'].get(key)!r} in OLD, "
                     f"{now['definition'].get(key)!r} here" for key in keys)
        if "targets" in now and before.get("targets") != now["targets"]:
            found.append(f"case {name}: other targets" + (" (the same settings and definition drew them: "
                         "the sampling code differs)" if not (keys or settings) else ""))
    return found


@dataclass(frozen=True)
class MethodComparison:
    """One (case, method), OLD's rows beside this run's, paired by target, and the verdict."""

    case: str
    label: str
    budget: str = ""  # "none", "iterations" or "wall" (method.json); "" when a run lacks the method
    poses: int = 0
    old_solved: int | None = None
    new_solved: int | None = None
    lost: tuple[int, ...] = ()  # pose ids solved in OLD, unsolved now
    gained: tuple[int, ...] = ()  # pose ids unsolved in OLD, solved now
    p_value: float = math.nan  # McNemar's exact one-sided p (wall-clock methods)
    ratio: tuple[float, float, float] = (math.nan, math.nan, math.nan)  # median new/old time, 95 % interval
    success_regressed: bool = False
    time_regressed: bool = False
    missing: str = ""  # why OLD's method has no rows here
    verdict: str = ""

    @property
    def regressed(self) -> bool:
        return self.success_regressed or self.time_regressed or bool(self.missing)


@dataclass(frozen=True)
class Comparison:
    """This run against OLD under ``rule``; ``refused``: what differs when the targets do."""

    old: Path
    rule: RegressionRule
    methods: list[MethodComparison] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    refused: list[str] = field(default_factory=list)

    @property
    def regressions(self) -> list[MethodComparison]:
        return [method for method in self.methods if method.regressed]


def mcnemar_p(lost: int, gained: int) -> float:
    """McNemar's exact one-sided p-value that success dropped: P(X >= lost), X ~ B(lost + gained, 1/2)."""
    return (float(stats.binomtest(lost, lost + gained, 0.5, alternative="greater").pvalue) if lost + gained
            else 1.0)


def _poses(ids) -> str:
    ids = [int(i) for i in ids]
    more = f" and {len(ids) - LISTED_POSES} more" if len(ids) > LISTED_POSES else ""
    return ", ".join(map(str, ids[:LISTED_POSES])) + more


def judge(case: str, label: str, budget: str, old: dict[str, np.ndarray], new: dict[str, np.ndarray],
          rule: RegressionRule) -> MethodComparison:
    """One method's rows in OLD and here (the same targets) paired target by target, and the verdict."""
    if not np.array_equal(old["pose"], new["pose"]):
        raise UsageError(f"case {case!r}, method {label!r}: the two runs' rows are of other poses")
    before, now = old["success"].astype(bool), new["success"].astype(bool)
    lost, gained = old["pose"][before & ~now], old["pose"][~before & now]
    p_value = math.nan if budget in DETERMINISTIC else mcnemar_p(lost.size, gained.size)
    success_regressed = lost.size > 0 if budget in DETERMINISTIC else p_value < rule.success_level
    timed = np.isfinite(old["time_s"]) & np.isfinite(new["time_s"]) & (old["time_s"] > 0)
    ratios = new["time_s"][timed] / old["time_s"][timed]
    ratio = (float(np.median(ratios)), *bootstrap_median_interval(ratios)) if ratios.size else \
        (math.nan, math.nan, math.nan)
    time_regressed = rule.time_rise is not None and ratio[1] > rule.time_rise
    words = []
    if success_regressed:
        test = "" if budget in DETERMINISTIC else \
            f" (McNemar exact, p = {fmt_p(p_value)} < {rule.success_level:g})"
        words.append(f"REGRESSION: {lost.size} target(s) solved in OLD unsolved now{test}: "
                     f"poses {_poses(lost)}")
    elif lost.size:
        words.append(f"{lost.size} lost, {gained.size} gained (McNemar exact p = {fmt_p(p_value)})")
    if time_regressed:
        words.append(f"REGRESSION: time per call rose: median ratio new/old {fmt(ratio[0])} "
                     f"{fmt_interval(ratio[1], ratio[2])} above x{rule.time_rise:g}")
    if not words:
        words.append(f"{gained.size} target(s) solved now unsolved in OLD" if gained.size else "no change")
        if rule.time_rise is not None and ratio[2] < 1.0 / rule.time_rise:
            words.append("faster")
    return MethodComparison(case, label, budget, int(now.size), int(before.sum()), int(now.sum()),
                            tuple(int(i) for i in lost), tuple(int(i) for i in gained), p_value, ratio,
                            success_regressed, bool(time_regressed), "", "; ".join(words))


def refusal_before_the_run(study: Study, old: Path) -> list[str]:
    """What differs in ``study``'s settings and case definitions from the run in ``old`` (before sampling)."""
    old_targets = store.read_json(Path(old) / TARGETS_RECORD)
    return [] if old_targets is None else differences(old_targets, targets_record(study))


def _method_record(folder: Path, case: str, label: str) -> dict:
    return store.read_json(store.case_dir(folder, case) / "chunks" / label / "method.json", {}) or {}


def _budget(folder: Path, case: str, label: str) -> str:
    return _method_record(folder, case, label).get("budget", "wall")  # not recorded: rows may vary


def _definition_note(old: Path, output: Path, case: str, label: str) -> list[str]:
    """A note when ``label`` ran with another definition in OLD (its method, options or budget)."""
    before, now = (_method_record(folder, case, label).get("method", {}) for folder in (old, output))
    changed = [f"{key} {before.get(key)!r} -> {now.get(key)!r}" for key in ("method", "options", "timeout_s")
               if before.get(key) != now.get(key)]
    return [f"{case}/{label} is defined otherwise than in OLD: {', '.join(changed)}"] if changed else []


def compare_runs(study: Study, output: Path, old: Path) -> Comparison:
    """This run (``output``) against the run folder ``old``; writes ``comparison.csv`` into ``output``."""
    old, output = Path(old), Path(output)
    if old.resolve() == output.resolve():
        raise UsageError(f"--compare-to {str(old)!r} is this run's own folder: pass the folder of an "
                         "earlier run")
    if (old_study := store.read_json(old / "study.json")) is None:
        raise UsageError(f"--compare-to {str(old)!r} holds no results of a study (no study.json): pass the "
                         "output folder of an earlier 'wbik study' run")
    old_targets = store.read_json(old / TARGETS_RECORD)
    refused = (differences(old_targets, store.read_json(output / TARGETS_RECORD)) if old_targets is not None
               else [f"OLD has no {TARGETS_RECORD} (the record of its targets): run its study again with "
                     "this wbik"])
    comparison = (Comparison(old, study.regression, refused=refused) if refused
                  else _paired(study, output, old, old_study.get("study", {}), old_targets))
    _write_csv(output / "comparison.csv", comparison)
    return comparison


def _paired(study: Study, output: Path, old: Path, old_study: dict, old_targets: dict) -> Comparison:
    """The comparison of two runs on the same targets, case by case (OLD's cases, then this run's)."""
    methods, notes = [], []
    chunk_size, labels = old_study["chunk_size"], [m["label"] for m in old_study.get("methods", [])]
    cases = {case.name: case for case in study.cases}
    for name, record in old_targets["cases"].items():
        poses = record["definition"]["poses"]
        chunks = -(-poses // chunk_size)
        old_rows = {label: rows for label in labels
                    if (rows := store.load_method_rows(old, name, label, chunks)) is not None}
        new_rows, refused = case_rows(study, cases[name], output) if name in cases else ({}, {})
        for label, rows in old_rows.items():
            if label in new_rows:
                methods.append(judge(name, label, _budget(output, name, label), rows, new_rows[label],
                                     study.regression))
                notes.extend(_definition_note(old, output, name, label))
                continue
            why = ("case not in this run" if name not in cases
                   else f"not applicable here: {refused[label]}" if label in refused
                   else "incomplete here" if label in {m.label for m in study.methods}
                   else "not in this run's study")
            verdict = "REGRESSION: its case is not in this run" if name not in cases else f"REGRESSION: {why}"
            methods.append(MethodComparison(name, label, _budget(old, name, label), poses,
                                            int(rows["success"].sum()), missing=why, verdict=verdict))
        notes.extend(f"{name}/{label} is not in OLD (nothing to compare)" for label in new_rows
                     if label not in old_rows)
    notes.extend(f"OLD has no case {name!r} (nothing to compare)" for name in cases
                 if name not in old_targets["cases"])
    return Comparison(old, study.regression, methods, notes)


def rule_text(rule: RegressionRule) -> str:
    """The rule in words."""
    time = ("times are not gated (time_rise: off)" if rule.time_rise is None else
            f"its time per call regressed when the 95 % bootstrap interval of the median per-target ratio "
            f"new/old lies wholly above {rule.time_rise:g}")
    return ("Paired by target: a method without a wall clock (closed form, iteration budget) regressed "
            "when any target solved in OLD is unsolved now; a wall-clock method when McNemar's exact "
            f"one-sided test on the targets solved in one run only gives p < {rule.success_level:g}; "
            f"{time}; a method or case of OLD that this run lacks regressed.")


def _cells(m: MethodComparison) -> list[str]:
    kind = {"none": "closed form", "iterations": "iterations", "wall": "wall clock"}.get(m.budget, "-")
    return [m.case, m.label, kind, fmt(m.old_solved), fmt(m.new_solved), str(len(m.lost)), str(len(m.gained)),
            fmt_p(m.p_value), fmt(m.ratio[0]), fmt_interval(m.ratio[1], m.ratio[2]), m.verdict]


def comparison_blocks(comparison: Comparison) -> list[Block]:
    """The report's section: the rule, then a row per case and method (or why nothing was compared)."""
    blocks = [Block("h2", f"Compared with {comparison.old}")]
    if comparison.refused:
        return [*blocks, Block("p", "Not compared: the two runs' targets differ (targets.json):"),
                Block("list", items=comparison.refused)]
    regressions = comparison.regressions
    named = ", ".join(f"{m.case}/{m.label}" for m in regressions)
    blocks.append(Block("p", rule_text(comparison.rule) + " (the study file's regression: block; "
                        "wbik.study.compare) " + (f"{len(regressions)} regression(s): {named}." if regressions
                                                  else "No regression.")))
    blocks.extend(Block("p", note + ".") for note in comparison.notes)
    blocks.append(Block("table", header=["case", "method", "budget", "solved OLD", "solved", "lost", "gained",
                                         "McNemar p", "time ratio new/old (median)", "95 % CI", "verdict"],
                        rows=[_cells(m) for m in comparison.methods]))
    return blocks


def summary_lines(comparison: Comparison) -> list[str]:
    """The comparison for a terminal: a line per case and method, regressions marked."""
    if comparison.refused:
        return [f"not compared with {comparison.old}: the runs' targets differ:",
                *(f"  {line}" for line in comparison.refused)]
    lines = [f"compared with {comparison.old}: {len(comparison.regressions)} regression(s). "
             + rule_text(comparison.rule)]
    lines.extend(f"  note: {note}" for note in comparison.notes)
    for m in comparison.methods:
        figures = "" if m.missing else (f" [{m.budget}] solved {m.old_solved} -> {m.new_solved}, time ratio "
                                        f"{fmt(m.ratio[0])} {fmt_interval(m.ratio[1], m.ratio[2])}:")
        lines.append(f"  {m.case} / {m.label}:{figures} {m.verdict}")
    return lines


def _write_csv(path: Path, comparison: Comparison) -> None:
    rows = [[m.case, m.label, m.budget, m.poses, m.old_solved, m.new_solved, len(m.lost), len(m.gained),
             repr(m.p_value), *(repr(value) for value in m.ratio), int(m.success_regressed),
             int(m.time_regressed), m.missing, m.verdict, " ".join(map(str, m.lost)), ""]
            for m in comparison.methods]
    store.write_csv(path, ["case", "method", "budget", "poses", "old_solved", "new_solved", "lost", "gained",
                           "mcnemar_p", "time_ratio_median", "time_ratio_ci_low", "time_ratio_ci_high",
                           "success_regressed", "time_regressed", "missing", "verdict", "lost_poses",
                           "refused"], [*rows, *([""] * 17 + [reason] for reason in comparison.refused)])
