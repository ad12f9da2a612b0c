"""Summary tables, 95 % intervals and significance tests over a study's raw rows: Wilson's score
interval for the share solved, the percentile bootstrap (fixed seed) for the median time, the two-sided
Mann-Whitney U test against the baseline, Holm-adjusted per axis (docs/guide/studies.md)."""

from __future__ import annotations

import math
import warnings
from functools import partial

import numpy as np
from scipy import stats

P95 = partial(np.percentile, q=95)
"""The 95th percentile of an array."""
TIME_STATISTICS = {"mean": np.mean, "median": np.median, "p95": P95, "min": np.min, "max": np.max}
ERROR_STATISTICS = {"mean": np.mean, "abs_median": np.median, "abs_p95": P95, "abs_max": np.max,
                    "zero_fraction": lambda magnitude: np.mean(magnitude == 0.0)}
"""Per error axis: the signed error's mean, then figures of |e|."""
ALPHA = 0.05
CONFIDENCE = 0.95
"""The level of every interval of the summaries."""
BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 2017
"""The bootstrap's random stream: fixed, so the same rows give the same intervals."""
_BOOTSTRAP_BLOCK = 2_000_000
"""Resampled values drawn at a time (memory: 8 bytes each)."""


def wilson_interval(successes: int, count: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Wilson's score interval (low, high) of k of n, as fractions ((nan, nan) for none): with p = k/n and
    z the normal quantile, centre (p + z^2/2n) / (1 + z^2/n), half-width z sqrt(p(1-p)/n + z^2/4n^2) /
    (1 + z^2/n)."""
    if count <= 0:
        return math.nan, math.nan
    z = float(stats.norm.ppf(0.5 + confidence / 2.0))  # 1.96 at 95 %
    p = successes / count
    denominator = 1.0 + z * z / count
    centre = (p + z * z / (2.0 * count)) / denominator
    half = z * math.sqrt(p * (1.0 - p) / count + z * z / (4.0 * count * count)) / denominator
    low = 0.0 if successes == 0 else max(0.0, centre - half)  # exactly 0 and 1 at the ends (no rounding)
    high = 1.0 if successes == count else min(1.0, centre + half)
    return low, high


def bootstrap_medians(values: np.ndarray, resamples: int = BOOTSTRAP_RESAMPLES,
                      seed: int = BOOTSTRAP_SEED) -> np.ndarray:
    """The medians of ``resamples`` resamples with replacement of the finite ``values`` (empty for none)."""
    values = np.asarray(values, dtype=float)[np.isfinite(values)]
    if values.size == 0:
        return np.zeros(0)
    rng = np.random.default_rng(seed)
    per_block = max(1, _BOOTSTRAP_BLOCK // values.size)
    draws = (rng.integers(0, values.size, (min(per_block, resamples - start), values.size))
             for start in range(0, resamples, per_block))
    return np.concatenate([np.median(values[draw], axis=1) for draw in draws])


def bootstrap_median_interval(values: np.ndarray, confidence: float = CONFIDENCE,
                              resamples: int = BOOTSTRAP_RESAMPLES,
                              seed: int = BOOTSTRAP_SEED) -> tuple[float, float]:
    """The percentile bootstrap interval of the median of the finite ``values``: the (1 - c)/2 and (1 + c)/2
    quantiles of the resamples' medians; (nan, nan) for none."""
    medians = bootstrap_medians(values, resamples, seed)
    if medians.size == 0:
        return math.nan, math.nan
    tail = 50.0 * (1.0 - confidence)
    low, high = np.percentile(medians, [tail, 100.0 - tail])
    return float(low), float(high)


def holm(p_values) -> np.ndarray:
    """Holm's step-down adjusted p-values in the order given (NaN stays NaN, not counted): with the m finite
    ones sorted, p~_(i) = min(1, max_{j <= i} (m - j + 1) p_(j))."""
    p_values = np.asarray(p_values, dtype=float)
    adjusted = np.full(p_values.shape, np.nan)
    finite = np.flatnonzero(np.isfinite(p_values))
    m = finite.size
    if m == 0:
        return adjusted
    order = finite[np.argsort(p_values[finite], kind="stable")]
    scaled = (m - np.arange(m)) * p_values[order]
    adjusted[order] = np.minimum(1.0, np.maximum.accumulate(scaled))
    return adjusted


def with_holm(tests: list[dict]) -> list[dict]:
    """Copies of the test rows with ``p_holm`` and ``significant_holm``, Holm's adjustment over each family
    (the tests of one axis against one baseline)."""
    families: dict[tuple, list[int]] = {}
    for index, test in enumerate(tests):
        families.setdefault((test["baseline"], test["axis"]), []).append(index)
    adjusted = [dict(test) for test in tests]
    for members in families.values():
        for index, p_value in zip(members, holm([tests[i]["p_value"] for i in members]), strict=True):
            adjusted[index]["p_holm"] = float(p_value)
            adjusted[index]["significant_holm"] = bool(p_value < ALPHA) if math.isfinite(p_value) else False
    return adjusted


def finite_statistic(values: np.ndarray, function=np.median) -> float:
    """``function`` of the finite ``values`` as a float; NaN when there are none."""
    values = np.asarray(values)[np.isfinite(values)]
    return float(function(values)) if values.size else math.nan


def error_axes(rows: dict[str, np.ndarray]) -> list[str]:
    """The error axes present in a method's rows (column names without ``err_``)."""
    return [key[4:] for key in rows if key.startswith("err_")]


def _cpu_figures(rows: dict[str, np.ndarray]) -> dict[str, float]:
    """Of the solves whose CPU time was measured (:mod:`wbik.study.cpu_watch`): the median CPU / wall of the
    answers kept (about the method's threads), and how many were re-run the most times allowed."""
    from wbik.study.cpu_watch import MAX_RERUNS

    if (cpu := rows.get("cpu_s")) is None:
        return {"cpu_per_wall_median": math.nan, "rerun_exhausted": 0}
    measured = np.isfinite(cpu) & np.isfinite(rows["time_s"]) & (rows["time_s"] > 0)
    share = cpu[measured] / rows["time_s"][measured]
    return {"cpu_per_wall_median": float(np.median(share)) if share.size else math.nan,
            "rerun_exhausted": int(np.sum(rows["reruns"] >= MAX_RERUNS)) if "reruns" in rows else 0}


BATCH_CALLS = 3
"""The calls over a whole case that each throughput figure is the best of."""


def throughput_figures(rows: dict[str, np.ndarray]) -> dict[str, float]:
    """Of a method with a batched path: poses per second of ``solve_many`` over the case in one process and
    over every core (NaN if a call raised), the cores used, the % solved, and the poses where a batch's
    verdict differs from ``solve``'s; NaN (and 0) without one."""
    batch = rows.get("batch_success")
    if batch is None:
        return {"throughput_poses_per_s": math.nan, "throughput_cores_poses_per_s": math.nan,
                "throughput_cores": math.nan, "throughput_percent_solved": math.nan,
                "throughput_disagreements": 0}

    def rate(name: str) -> float:
        seconds = float(np.sum(rows[name])) if name in rows else math.nan  # (NaN: rows from before)
        return batch.size / seconds if seconds > 0 else math.nan

    batch, solved = batch.astype(bool), rows["success"].astype(bool)
    disagree = batch != solved
    if "batch_cores_success" in rows:
        disagree |= rows["batch_cores_success"].astype(bool) != solved
    workers = rows.get("batch_workers")
    return {"throughput_poses_per_s": rate("batch_share_s"),
            "throughput_cores_poses_per_s": rate("batch_cores_share_s"),
            "throughput_cores": float(workers[0]) if workers is not None and batch.size else math.nan,
            "throughput_percent_solved": 100.0 * float(np.mean(batch)) if batch.size else math.nan,
            "throughput_disagreements": int(np.sum(disagree))}


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
    summary.update(_cpu_figures(rows))
    summary.update(throughput_figures(rows))
    low, high = wilson_interval(solved, count)
    summary["percent_solved_ci_low"], summary["percent_solved_ci_high"] = 100.0 * low, 100.0 * high
    for group, mask in (("all", np.ones(count, dtype=bool)), ("solved", success), ("unsolved", ~success)):
        for name, function in TIME_STATISTICS.items():
            summary[f"time_{group}_{name}_ms"] = finite_statistic(times_ms[mask], function)
    for group, mask in (("all", np.ones(count, dtype=bool)), ("solved", success)):
        low, high = bootstrap_median_interval(times_ms[mask])
        summary[f"time_{group}_median_ci_low_ms"], summary[f"time_{group}_median_ci_high_ms"] = low, high
    finite_times = times_ms[np.isfinite(times_ms)]
    for limit in (10, 500):
        summary[f"percent_under_{limit}ms"] = (100.0 * float(np.mean(finite_times < limit))
                                               if finite_times.size else math.nan)
    for axis in error_axes(rows):
        values = rows[f"err_{axis}"][success]
        for name, function in ERROR_STATISTICS.items():
            summary[f"err_{axis}_{name}"] = finite_statistic(values if name == "mean" else np.abs(values),
                                                             function)
    return summary


def significance_samples(rows: dict[str, np.ndarray], axis: str) -> np.ndarray:
    """The sample compared for one axis: |e| of solved poses, or the time (ms) of every pose."""
    return (rows["time_s"] * 1e3 if axis == "time"
            else np.abs(rows[f"err_{axis}"][rows["success"].astype(bool)]))


def significance(baseline_label: str, rows_by_method: dict[str, dict[str, np.ndarray]]) -> list[dict]:
    """A Mann-Whitney row per (method, axis) against the baseline, axes then "time", Holm-adjusted."""
    if baseline_label not in rows_by_method:
        return []
    baseline = rows_by_method[baseline_label]
    return with_holm([mann_whitney_row(label, baseline_label, axis, significance_samples(baseline, axis),
                                       significance_samples(rows, axis))
                      for label, rows in rows_by_method.items() if label != baseline_label
                      for axis in [*error_axes(baseline), "time"] if axis == "time" or f"err_{axis}" in rows])


def mann_whitney_row(method: str, baseline: str, axis: str, first: np.ndarray, second: np.ndarray) -> dict:
    """The row of scipy's two-sided Mann-Whitney U test of ``method``'s sample ``second`` against the
    baseline's ``first``, on their finite values (U and p NaN when a sample is empty)."""
    a, b = first[np.isfinite(first)], second[np.isfinite(second)]
    statistic = pvalue = math.nan
    if a.size and b.size:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            result = stats.mannwhitneyu(a, b, alternative="two-sided")
        statistic, pvalue = float(result.statistic), float(result.pvalue)
    return {"method": method, "baseline": baseline, "axis": axis, "n_baseline": int(a.size),
            "n_method": int(b.size), "median_baseline": float(np.median(a)) if a.size else math.nan,
            "median_method": float(np.median(b)) if b.size else math.nan, "U": statistic, "p_value": pvalue,
            "significant": bool(pvalue < ALPHA) if math.isfinite(pvalue) else False}
