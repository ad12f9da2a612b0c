"""The figure every benchmark reports: ours against a peer measured in the same process and run.

Each benchmark module that ``benchmarks/all.py`` runs exposes ``ratios(quick: bool = False) ->
list[Ratio]``; ``quick=True`` finishes in well under a minute (the smoke test runs it), the full run
in a few minutes. A ratio is ``ours / peer``; a goal bounds it (``limit``) from above when smaller
is better (times) or from below when larger is better (success rates, throughput).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass

UNITS = ("s/call", "s/pose", "s/step", "s/solve", "fraction", "poses/s", "Hz")
SPARE = 1.25
"""A goal counts as kept on other machines of the kind when met with this factor to spare (ratios measured
here were up to 1.5x worse on another machine of the same kind)."""


def best_of_rounds(measurements: dict[Hashable, Callable[[], float]], rounds: int) -> dict[Hashable, float]:
    """Each measurement's smallest value over ``rounds`` rounds, every measurement taken once per round:
    interleaved, so that a slow phase of the machine (a second or more here) falls on all of them
    alike instead of on every run of one."""
    best = dict.fromkeys(measurements, math.inf)
    for _ in range(rounds):
        for label, measure in measurements.items():
            best[label] = min(best[label], measure())
    return best


@dataclass(frozen=True)
class Ratio:
    """One comparison: ``ours`` and ``peer`` in ``unit``; met when the ratio is on the goal's side."""

    goal: str  # wbik's goal in words, e.g. "UR5 solve <= 2x EAIK all branches"
    ours_label: str
    ours: float
    peer_label: str
    peer: float
    unit: str
    limit: float | None = None  # bound on ours / peer; None: informational
    better: str = "lower"  # "lower": met when ratio <= limit; "higher": met when ratio >= limit
    note: str = ""  # what the figures count (solved only / all calls, poses, best of N)

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise ValueError(f"unit must be one of {UNITS}, got {self.unit!r}")
        if self.better not in ("lower", "higher"):
            raise ValueError(f"better must be 'lower' or 'higher', got {self.better!r}")
        if not (math.isfinite(self.ours) and math.isfinite(self.peer)) or self.peer <= 0.0:
            raise ValueError(f"{self.goal}: figures must be finite and the peer's positive "
                             f"(ours={self.ours}, peer={self.peer})")

    @property
    def ratio(self) -> float:
        return self.ours / self.peer

    @property
    def met(self) -> bool | None:
        """True/False against the goal, None when informational."""
        if self.limit is None:
            return None
        return self.ratio <= self.limit if self.better == "lower" else self.ratio >= self.limit

    @property
    def spared(self) -> bool | None:
        """Met with :data:`SPARE` to spare (ratio x 1.25 within the bound, or ratio / 1.25); None: info."""
        if self.limit is None:
            return None
        if self.better == "lower":
            return self.ratio * SPARE <= self.limit
        return self.ratio >= SPARE * self.limit

    def verdict(self) -> str:
        met = self.met
        if met is None:
            return "info"
        sign = "<=" if self.better == "lower" else ">="
        kept = ", 25 % to spare" if self.spared else ", not 25 % to spare" if met else ""
        return f"{'met' if met else 'MISSED'}{kept} ({sign} {self.limit:g})"
