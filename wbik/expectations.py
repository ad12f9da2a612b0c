"""Figures judged against a task file's thresholds (``com_margin_min_m: 0.005``: ``com_margin_m`` >= 0.005).
A value is the threshold or ``{threshold, expected_to_fail, why}`` (a strict xfail)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from wbik.errors import WbikError

OPERATORS = {">=": lambda a, b: a >= b, "<=": lambda a, b: a <= b, "==": lambda a, b: a == b}


class ExpectationError(WbikError, ValueError):
    """An ``expect:`` block with an unknown key or an unusable threshold."""


@dataclass(frozen=True)
class Rule:
    """``figure op threshold`` must hold; ``figure`` names a value in the runner's figures."""

    figure: str
    op: str  # ">=", "<=" or "=="
    unit: str = ""

    def __post_init__(self):
        if self.op not in OPERATORS:
            raise ValueError(f"unknown operator {self.op!r}; use one of {sorted(OPERATORS)}")


def evaluate(expect: Mapping | None, figures: Mapping[str, object], rules: Mapping[str, Rule],
             where: str = "expect") -> list[dict]:
    """One check per key of ``expect`` (see the module docstring); ``figures`` holds the values."""
    expect = dict(expect or {})
    if unknown := sorted(set(expect) - set(rules)):
        raise ExpectationError(f"{where}: unknown expectation key(s) {unknown}; known keys: {sorted(rules)}")
    checks = []
    for key, value in expect.items():
        rule = rules[key]
        entry = value if isinstance(value, Mapping) else {"threshold": value}
        if set(entry) - {"threshold", "expected_to_fail", "why"} or "threshold" not in entry:
            raise ExpectationError(f"{where}: expectation {key!r} as a mapping needs 'threshold' and may "
                                   f"have 'expected_to_fail' and 'why'; got keys {sorted(entry)}")
        threshold, expected_to_fail = entry["threshold"], bool(entry.get("expected_to_fail", False))
        why = str(entry.get("why", "") or "")
        if expected_to_fail and not why.strip():
            raise ExpectationError(f"{where}: expectation {key!r} is expected_to_fail but gives no 'why'")
        numeric = isinstance(threshold, (int, float)) and not isinstance(threshold, bool)
        if not (numeric or (rule.op == "==" and isinstance(threshold, bool))):
            wanted = "a number or a bool" if rule.op == "==" else "a number"
            raise ExpectationError(f"{where}: expectation {key!r} needs {wanted} as threshold, "
                                   f"got {threshold!r}")
        figure = figures.get(rule.figure)
        if isinstance(figure, float) and math.isnan(figure):
            figure = None
        ok = figure is not None and bool(OPERATORS[rule.op](figure, threshold))
        checks.append({"name": key, "figure_name": rule.figure, "figure": figure, "op": rule.op,
                       "threshold": threshold, "unit": rule.unit, "ok": ok,
                       "expected_to_fail": expected_to_fail, "why": why,
                       "passed": ok != expected_to_fail})
    return checks


def verdict(checks: Iterable[dict]) -> str:
    """``FAILED`` if any check did not pass, ``informational`` if there is none, else ``PASSED``."""
    checks = list(checks)
    if not checks:
        return "informational"
    return "PASSED" if all(check["passed"] for check in checks) else "FAILED"


def judge(entry: dict, expect: Mapping | None, figures: Mapping[str, object], rules: Mapping[str, Rule],
          where: str = "expect") -> dict:
    """``entry`` with the checks of ``expect`` (``expectations``), their ``verdict`` and ``passed``."""
    entry["expectations"] = evaluate(expect, figures, rules, where)
    entry["verdict"] = verdict(entry["expectations"])
    entry["passed"] = entry["verdict"] != "FAILED"
    return entry


def _value(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def format_checks(checks: Iterable[dict], indent: str = "      ") -> list[str]:
    """One line per check: figure / threshold / ok, and the reason of an expected failure."""
    lines = []
    for check in checks:
        unit = f" {check['unit']}" if check["unit"] else ""
        status = "ok" if check["ok"] else "NOT ok"
        if check["expected_to_fail"]:
            status += (" (expected to fail: " + check["why"] + ")" if not check["ok"]
                       else " but expected to fail: FAILED (update the task file)")
        elif not check["ok"]:
            status += ": FAILED"
        lines.append(f"{indent}{check['name']}: {check['figure_name']} {_value(check['figure'])}{unit} / "
                     f"{check['op']} {_value(check['threshold'])}{unit} / {status}")
    return lines
