"""The study's intervals and multiple-test correction: Wilson intervals against Newcombe's published
values, the percentile bootstrap of a median (seeded, 2,000 resamples), Holm's step-down adjustment
against a hand-computed case, and the summary and significance rows that carry them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbik.study.statistics import (
    BOOTSTRAP_RESAMPLES,
    bootstrap_median_interval,
    bootstrap_medians,
    holm,
    significance,
    summarize,
    wilson_interval,
    with_holm,
)


@pytest.mark.parametrize(("solved", "count", "low", "high"), [
    # Newcombe (1998), "Two-sided confidence intervals for the single proportion", Table I, method 3
    (81, 263, 0.2553, 0.3662),
    (15, 148, 0.0624, 0.1605),
    (0, 20, 0.0, 0.1611),
    (1, 29, 0.0061, 0.1718),
    (29, 29, 0.8830, 1.0),
])
def test_wilson_intervals_match_newcombe_s_table(solved, count, low, high):
    assert wilson_interval(solved, count) == pytest.approx((low, high), abs=5e-5)


def test_wilson_interval_is_not_degenerate_at_100_percent():
    low, high = wilson_interval(1000, 1000)
    assert high == 1.0 and 0.995 < low < 0.997  # where a bootstrap would give [1, 1]
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


def test_bootstrap_median_interval_is_seeded_and_brackets_the_median():
    values = np.random.default_rng(3).lognormal(size=500)
    low, high = bootstrap_median_interval(values)
    assert low < np.median(values) < high
    assert (low, high) == bootstrap_median_interval(values)  # the same rows, the same interval
    medians = bootstrap_medians(values)
    assert medians.size == BOOTSTRAP_RESAMPLES
    assert (low, high) == pytest.approx(tuple(np.percentile(medians, [2.5, 97.5])))
    # the interval is that of the median: about +-1.96 sqrt(pi/2) sigma / sqrt(n) for a normal sample
    normal = np.random.default_rng(4).normal(size=4000)
    low, high = bootstrap_median_interval(normal)
    assert high - low == pytest.approx(2 * 1.96 * math.sqrt(math.pi / 2) / math.sqrt(4000), rel=0.2)


def test_bootstrap_ignores_missing_values_and_has_no_interval_without_values():
    assert bootstrap_median_interval(np.array([1.0, np.nan, 1.0])) == (1.0, 1.0)
    assert all(math.isnan(v) for v in bootstrap_median_interval(np.array([np.nan])))


def test_holm_against_a_hand_computed_case():
    # sorted: 0.005 (x4 = 0.02), 0.01 (x3 = 0.03), 0.03 (x2 = 0.06), 0.04 (x1 = 0.04 -> max 0.06)
    adjusted = holm([0.01, 0.04, 0.03, 0.005, math.nan])
    assert adjusted[:4] == pytest.approx([0.03, 0.06, 0.06, 0.02])
    assert math.isnan(adjusted[4])  # not counted among the m = 4
    assert holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])  # capped at 1
    assert holm([0.2]) == pytest.approx([0.2])  # one test: unchanged


def test_holm_is_applied_per_axis_over_the_methods_compared():
    tests = [{"method": m, "baseline": "base", "axis": axis, "p_value": p}
             for m, axis, p in (("a", "x", 0.01), ("b", "x", 0.02), ("a", "time", 0.04), ("b", "time", 0.3))]
    adjusted = {(t["method"], t["axis"]): t for t in with_holm(tests)}
    assert adjusted["a", "x"]["p_holm"] == pytest.approx(0.02)  # 2 x 0.01
    assert adjusted["b", "x"]["p_holm"] == pytest.approx(0.02)  # max(0.02, 1 x 0.02)
    assert adjusted["a", "time"]["p_holm"] == pytest.approx(0.08)
    assert adjusted["a", "time"]["significant_holm"] is False
    assert adjusted["a", "x"]["significant_holm"] is True
    assert "p_holm" not in tests[0]  # copies


def _rows(success, times_s, errors):
    count = len(success)
    return {"success": np.array(success, dtype=bool), "time_s": np.array(times_s, dtype=float),
            "reason": np.array([""] * count), "iterations": np.ones(count, dtype=int),
            "q": np.zeros((count, 2)), "err_x": np.array(errors, dtype=float)}


def test_summary_and_significance_carry_the_intervals_and_holm():
    rng = np.random.default_rng(0)
    base = _rows(rng.random(200) < 0.9, rng.lognormal(-7, 0.3, 200), rng.normal(0, 1e-9, 200))
    other = _rows(rng.random(200) < 0.6, rng.lognormal(-6, 0.3, 200), rng.normal(0, 1e-8, 200))
    summary = summarize(other)
    low, high = wilson_interval(summary["solved"], 200)
    assert (summary["percent_solved_ci_low"], summary["percent_solved_ci_high"]) == (100 * low, 100 * high)
    assert (summary["time_all_median_ci_low_ms"] < summary["time_all_median_ms"]
            < summary["time_all_median_ci_high_ms"])
    assert (summary["time_solved_median_ci_low_ms"], summary["time_solved_median_ci_high_ms"]) == \
        bootstrap_median_interval(other["time_s"][other["success"]] * 1e3)
    tests = significance("base", {"base": base, "a": other, "b": base})
    for axis in ("x", "time"):
        family = [t for t in tests if t["axis"] == axis]
        assert [t["p_holm"] for t in family] == pytest.approx(list(holm([t["p_value"] for t in family])))
