"""Published figures a study sets beside its own, as a case's ``reference:`` block gives them::

    reference:
      name: paper                       # "Beside the paper", columns "paper"
      source: "Smith et al. 2020, section 5"
      angles: {sequence: zyx, names: {x: paper_roll, y: paper_pitch, z: paper_yaw}}  # wbik.study.metrics
      figures: {analytic: {percent_solved: 94.0, time_median_ms: 1.95}}    # metrics of REFERENCE_METRICS
      significance: {kdl: {x: 0, paper_yaw: 6.0e-6, time: 0}}              # p-values against the baseline

A percentage agrees within ``AGREEMENT_POINTS`` points; another figure is compared by the ratio ours /
theirs; p-values agree when both are, or both are not, below ``ALPHA``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from wbik.study.metrics import AngleConvention
from wbik.study.statistics import ALPHA


@dataclass(frozen=True)
class ReferenceMetric:
    """A figure a reference may quote: the summary.csv key it is compared with, in words, and its unit."""

    summary_key: str
    description: str
    unit: str


REFERENCE_METRICS = {
    "percent_solved": ReferenceMetric("percent_solved", "poses solved", "%"),
    "time_median_ms": ReferenceMetric("time_all_median_ms", "median time, all poses", "ms"),
    "time_median_solved_ms": ReferenceMetric("time_solved_median_ms", "median time, solved poses", "ms"),
    "time_mean_ms": ReferenceMetric("time_all_mean_ms", "mean time, all poses", "ms"),
    "time_min_ms": ReferenceMetric("time_all_min_ms", "minimum time, all poses", "ms"),
    "time_max_ms": ReferenceMetric("time_all_max_ms", "maximum time, all poses", "ms"),
    "time_mean_unsolved_ms": ReferenceMetric("time_unsolved_mean_ms", "mean time to decide 'no solution'",
                                             "ms"),
    "percent_under_10ms": ReferenceMetric("percent_under_10ms", "poses answered in under 10 ms", "%"),
    "percent_under_500ms": ReferenceMetric("percent_under_500ms", "poses answered in under 0.5 s", "%"),
}
"""The metrics a reference block may quote, by the name the file uses."""

AGREEMENT_POINTS = 2.0
"""Absolute difference (percentage points) within which a percentage counts as "agrees"."""


@dataclass(frozen=True)
class Reference:
    """A study case's ``reference:`` block, validated (see the module docstring)."""

    name: str = "reference"
    source: str = ""
    angles: AngleConvention | None = None
    figures: dict = field(default_factory=dict)  # {label: {metric: value}}
    significance: dict = field(default_factory=dict)  # {label: {axis: p-value}}
    significance_source: str = ""
    notes: str = ""

    @property
    def title(self) -> str:
        """The name at the start of a sentence ("Paper figures from ...")."""
        return self.name[:1].upper() + self.name[1:]

    @property
    def labels(self) -> list[str]:
        """The method labels the block quotes figures or p-values of."""
        return list(dict.fromkeys([*self.figures, *self.significance]))


def our_figures(summary: dict[str, float]) -> dict[str, float]:
    """Our value of every metric of REFERENCE_METRICS, from one method's summary."""
    return {name: summary[metric.summary_key] for name, metric in REFERENCE_METRICS.items()}


def verdict(metric: str, theirs: float, ours: float | None) -> str:
    """How our figure compares with the reference's (see the module docstring)."""
    if ours is None or not math.isfinite(ours):
        return "not measured (method not run)"
    if REFERENCE_METRICS[metric].unit == "%":
        difference = ours - theirs
        return (f"agrees ({difference:+.1f} points)" if abs(difference) <= AGREEMENT_POINTS
                else f"differs by {difference:+.1f} points")
    if theirs == 0:
        return "-"
    ratio = ours / theirs
    return f"{'same order' if 0.5 <= ratio <= 2.0 else 'faster' if ratio < 1 else 'slower'} (x{ratio:.2g})"


def same_significance(theirs: float, ours: float | None) -> str:
    """"yes" when both p-values are significant at ALPHA or both are not, "no" else, "-" unmeasured."""
    if ours is None or not math.isfinite(ours):
        return "-"
    return "yes" if (ours < ALPHA) == (theirs < ALPHA) else "no"
