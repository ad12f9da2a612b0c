"""A study case's own success rule, applied to the errors of every answer beside the shared FK check.

``per: norm``: |e_p| <= position and |e_r| <= rotation (cuRobo's and PyRoki's thresholds). ``per: axis``:
each component within its bound (TRAC-IK's test), the errors written in ``frame: target`` (e_p = R*^T
(p - p*), e_r = log3(R*^T R)) or ``frame: base`` (e_p = p - p*, e_r = R* log3(R*^T R)); a per-axis bound b
implies the norm bound sqrt(3) b. The errors come from the rows' per-axis columns
(:func:`wbik.study.metrics.axis_errors`); an answer without joints fails every rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RULES = ("norm", "axis")
FRAMES = ("target", "base")
AXES = ("x", "y", "z", "rot_x", "rot_y", "rot_z")
"""The six error components a per-axis rule bounds, in column order."""
PERCENTILES = (50.0, 98.0, 100.0)
"""The percentiles of the position and rotation errors a case with a rule reports (100: the maximum)."""


@dataclass(frozen=True)
class SuccessRule:
    """Bounds ``position`` (m) and ``rotation`` (rad) on the norms (``per`` "norm") or on each axis ("axis")
    in ``frame`` ("target" or "base")."""

    position: float
    rotation: float
    per: str = "norm"
    frame: str = "target"

    def describe(self) -> str:
        """The rule in words."""
        if self.per == "axis":
            return (f"every axis within {self.position:g} m and {self.rotation:g} rad (errors in the "
                    f"{self.frame} frame)")
        return f"position error <= {self.position:g} m and rotation error <= {self.rotation:g} rad (norms)"


def frame_errors(position_xyz: np.ndarray, rotation_xyz: np.ndarray, rotations: np.ndarray,
                 frame: str) -> tuple[np.ndarray, np.ndarray]:
    """(e_p, e_r), each (B, 3), in ``frame`` from the rows' p - p* (base axes) and log3(R*^T R) (target
    axes) and the targets' rotations R* (B, 3, 3)."""
    position_xyz = np.asarray(position_xyz, float)
    rotation_xyz = np.asarray(rotation_xyz, float)
    rotations = np.asarray(rotations, float)
    if frame == "target":
        return np.einsum("bji,bj->bi", rotations, position_xyz), rotation_xyz
    if frame == "base":
        return position_xyz, np.einsum("bij,bj->bi", rotations, rotation_xyz)
    raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")


def judge(rule: SuccessRule, position_xyz: np.ndarray, rotation_xyz: np.ndarray, rotations: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(passed, worst ratio |error| / bound, worst component), each (B,), of each answer under ``rule``; the
    component indexes :data:`AXES` (a norm rule: 0 position, 1 rotation); NaN without joints (failed)."""
    position, rotation = frame_errors(position_xyz, rotation_xyz, rotations, rule.frame)
    if rule.per == "axis":
        ratios = np.hstack([np.abs(position) / rule.position, np.abs(rotation) / rule.rotation])
    elif rule.per == "norm":
        ratios = np.stack([np.linalg.norm(position, axis=1) / rule.position,
                           np.linalg.norm(rotation, axis=1) / rule.rotation], axis=1)
    else:
        raise ValueError(f"per must be one of {RULES}, got {rule.per!r}")
    missing = ~np.all(np.isfinite(ratios), axis=1)
    worst_axis = np.argmax(np.nan_to_num(ratios, nan=np.inf), axis=1)
    worst = np.where(missing, np.nan, ratios[np.arange(len(ratios)), worst_axis])
    passed = ~missing & (np.nan_to_num(worst, nan=np.inf) <= 1.0)
    return passed, worst, worst_axis


def failure_reason(rule: SuccessRule, worst: float, component: int) -> str:
    """Why an answer the shared check passed fails ``rule`` (its worst component, its ratio to the bound)."""
    if rule.per == "axis":
        axis = AXES[component]
        bound, unit = (rule.rotation, "rad") if axis.startswith("rot") else (rule.position, "m")
        return (f"outside the case's success rule: |{axis}| = {worst * bound:.3g} {unit} > {bound:g} "
                f"({rule.frame} frame)")
    bound, what, unit = ((rule.position, "position", "m") if component == 0
                         else (rule.rotation, "rotation", "rad"))
    return f"outside the case's success rule: {what} error {worst * bound:.3g} {unit} > {bound:g}"


def error_percentiles(values: np.ndarray, percentiles=PERCENTILES) -> list[float]:
    """The ``percentiles`` of the finite ``values`` (NaN for none)."""
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return [float("nan")] * len(percentiles)
    return [float(v) for v in np.percentile(values, percentiles)]
