"""Summary tables and significance tests over a study's raw rows (numpy and scipy only).

Per method: poses solved; time (ms) mean / median / p95 / min / max over all, solved and unsolved
poses separately (the time to decide "no solution" is a figure of its own); per error axis over the
*solved* poses: mean signed error, median / p95 / max of |e| and the fraction of exact zeros.

Significance: the two-sided Mann-Whitney U test
(``scipy.stats.mannwhitneyu(a, b, alternative="two-sided")``) of each method against the baseline,
per error axis on |e| of the solved poses of each, and on the time of all poses.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy import stats

TIME_GROUPS = ("all", "solved", "unsolved")
TIME_STATISTICS = ("mean", "median", "p95", "min", "max")
ALPHA = 0.05


def _time_statistics(times_ms: np.ndarray) -> dict[str, float]:
    times_ms = times_ms[np.isfinite(times_ms)]
    if times_ms.size == 0:
        return {name: math.nan for name in TIME_STATISTICS}
    return {"mean": float(np.mean(times_ms)), "median": float(np.median(times_ms)),
            "p95": float(np.percentile(times_ms, 95)), "min": float(np.min(times_ms)),
            "max": float(np.max(times_ms))}


def error_axes(rows: dict[str, np.ndarray]) -> list[str]:
    """The error axes present in a method's rows (column names without ``err_``)."""
    return [key[4:] for key in rows if key.startswith("err_")]


def summarize(rows: dict[str, np.ndarray]) -> dict[str, float]:
    """Flat summary of one method's rows (keys as in the summary.csv header)."""
    success = rows["success"].astype(bool)
    count = int(success.size)
    solved = int(success.sum())
    times_ms = rows["time_s"] * 1e3
    summary: dict[str, float] = {
        "poses": count, "solved": solved, "percent_solved": 100.0 * solved / count if count else math.nan,
        "raised": int(sum(str(r).startswith("raised") for r in rows["reason"])),
        "no_joints": int(np.sum(~np.all(np.isfinite(rows["q"]), axis=1))) if "q" in rows else 0,
        "iterations_median": float(np.median(rows["iterations"])) if count else math.nan,
        "rerun": int(np.sum(rows["reruns"] > 0)) if "reruns" in rows else 0,
    }
    for group, mask in (("all", np.ones(count, dtype=bool)), ("solved", success), ("unsolved", ~success)):
        for name, value in _time_statistics(times_ms[mask]).items():
            summary[f"time_{group}_{name}_ms"] = value
    finite_times = times_ms[np.isfinite(times_ms)]
    for limit in (10, 500):
        summary[f"percent_under_{limit}ms"] = (100.0 * float(np.mean(finite_times < limit))
                                               if finite_times.size else math.nan)
    for axis in error_axes(rows):
        values = rows[f"err_{axis}"][success]
        values = values[np.isfinite(values)]
        magnitude = np.abs(values)
        empty = values.size == 0
        summary[f"err_{axis}_mean"] = math.nan if empty else float(np.mean(values))
        summary[f"err_{axis}_abs_median"] = math.nan if empty else float(np.median(magnitude))
        summary[f"err_{axis}_abs_p95"] = math.nan if empty else float(np.percentile(magnitude, 95))
        summary[f"err_{axis}_abs_max"] = math.nan if empty else float(np.max(magnitude))
        summary[f"err_{axis}_zero_fraction"] = math.nan if empty else float(np.mean(magnitude == 0.0))
    return summary


def mann_whitney(first: np.ndarray, second: np.ndarray) -> tuple[float, float]:
    """(U, two-sided p) of scipy's Mann-Whitney U test; NaN when a sample is empty."""
    first = first[np.isfinite(first)]
    second = second[np.isfinite(second)]
    if first.size == 0 or second.size == 0:
        return math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        result = stats.mannwhitneyu(first, second, alternative="two-sided")
    return float(result.statistic), float(result.pvalue)


def significance_samples(rows: dict[str, np.ndarray], axis: str) -> np.ndarray:
    """The sample compared for one axis: |e| of solved poses, or the time (ms) of every pose."""
    if axis == "time":
        return rows["time_s"] * 1e3
    return np.abs(rows[f"err_{axis}"][rows["success"].astype(bool)])


def significance(baseline_label: str, rows_by_method: dict[str, dict[str, np.ndarray]]) -> list[dict]:
    """One row per (method, axis) of Mann-Whitney U against the baseline, axes then "time"."""
    if baseline_label not in rows_by_method:
        return []
    baseline = rows_by_method[baseline_label]
    table = []
    for label, rows in rows_by_method.items():
        if label == baseline_label:
            continue
        for axis in [*error_axes(baseline), "time"]:
            if axis != "time" and f"err_{axis}" not in rows:
                continue
            a = significance_samples(baseline, axis)
            b = significance_samples(rows, axis)
            statistic, pvalue = mann_whitney(a, b)
            a, b = a[np.isfinite(a)], b[np.isfinite(b)]
            table.append({
                "method": label, "baseline": baseline_label, "axis": axis,
                "n_baseline": int(a.size), "n_method": int(b.size),
                "median_baseline": float(np.median(a)) if a.size else math.nan,
                "median_method": float(np.median(b)) if b.size else math.nan,
                "U": statistic, "p_value": pvalue,
                "significant": bool(pvalue < ALPHA) if math.isfinite(pvalue) else False,
            })
    return table
