"""A study case's own success rule on every answer's errors, beside the shared FK check: bounds on the norms
(``per: norm``) or on each axis (``per: axis``, TRAC-IK's test); an answer without joints fails every rule."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RULES = ("norm", "axis")
FRAMES = ("target", "base")
AXES = ("x", "y", "z", "rot_x", "rot_y", "rot_z")  # the components a per-axis rule bounds
PERCENTILES = (50.0, 98.0, 100.0)  # of the errors a case with a rule reports (100: the maximum)


@dataclass(frozen=True)
class SuccessRule:
    """Bounds ``position`` (m) and ``rotation`` (rad) on the norms or on each axis in ``frame``."""

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
    """(e_p, e_r) (B, 3) from p - p* (base axes) and log3(R*^T R) (target axes), with R* (B, 3, 3): target,
    (R*^T (p - p*), log3(R*^T R)); base, (p - p*, R* log3(R*^T R))."""
    position_xyz, rotation_xyz, rotations = (np.asarray(array, float)
                                             for array in (position_xyz, rotation_xyz, rotations))
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
    return ~missing & (np.nan_to_num(worst, nan=np.inf) <= 1.0), worst, worst_axis


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
    values = np.asarray(values, float)[np.isfinite(values)]
    return ([float(v) for v in np.percentile(values, percentiles)] if values.size
            else [float("nan")] * len(percentiles))
