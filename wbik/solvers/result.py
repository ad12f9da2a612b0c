"""What every method returns, :class:`IKResult`, judged under one set of :class:`Tolerances`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wbik.errors import InvalidSettingError, InvalidToleranceError
from wbik.files import json_plain
from wbik.schema import Number


@dataclass(frozen=True)
class Tolerances:
    """The shared check: an answer succeeds when every goal's errors are at or below these."""

    position: float = 1e-6  # metres (norm of a position error)
    rotation: float = 1e-6  # radians (angle of a rotation error)

    def __post_init__(self) -> None:
        for name, unit in (("position", "m"), ("rotation", "rad")):
            value = Number(gt=0, unit=unit, as_float=True).checked(getattr(self, name), f"tolerances.{name}",
                                                                   "Tolerances", InvalidToleranceError)
            object.__setattr__(self, name, value)


def checked_tolerances(tolerances: Tolerances | None) -> Tolerances:
    """``tolerances``, or Tolerances() for None; InvalidSettingError for anything else."""
    if tolerances is None:
        return Tolerances()
    if not isinstance(tolerances, Tolerances):
        raise InvalidSettingError(
            f"tolerances must be wbik.Tolerances(position=..., rotation=...), got {tolerances!r}")
    return tolerances


@dataclass(slots=True)
class Candidate:
    """What a method found, before the shared check."""

    q: np.ndarray | None
    iterations: int = 0
    reason: str = ""
    extra: dict = field(default_factory=dict)


NAN3 = (math.nan, math.nan, math.nan)


@dataclass(slots=True)
class IKResult:
    """The answer of every method: ``q`` (None without joints, else inside the limits) and its errors by FK,
    the largest goal's (m, rad), reached - target and log3(R*^T R) (NaN for a whole-body problem, which also
    fills ``task_errors``, ``measures``, ``unsupported`` and ``diagnosis`` of a failure)."""

    q: np.ndarray | None
    success: bool
    reason: str
    position_error: float
    rotation_error: float
    position_error_xyz: np.ndarray
    rotation_error_xyz: np.ndarray
    time_s: float
    iterations: int
    method: str = ""
    extra: dict = field(default_factory=dict)
    task_errors: dict[str, float] = field(default_factory=dict)
    task_position_errors: dict[str, float] = field(default_factory=dict)
    task_rotation_errors: dict[str, float] = field(default_factory=dict)
    measures: dict[str, Any] = field(default_factory=dict)
    unsupported: list[str] = field(default_factory=list)
    diagnosis: Any = None

    def _worst(self, quantity: str, worst, empty: float) -> float:
        values = [m.value for m in self.measures.values() if m.quantity == quantity]
        if self.q is None and self.task_errors:
            return math.nan
        return worst(values) if values else empty

    @property
    def contact_drift(self) -> float:
        """The largest contact drift (m or rad), 0 without contacts."""
        return self._worst("contact drift", max, 0.0)

    @property
    def com_margin(self) -> float:
        """The CoM's distance inside the support polygon (m, negative outside), NaN without support."""
        return self._worst("CoM margin", min, math.nan)

    @property
    def limit_excess(self) -> float:
        """How far a joint is beyond its limits (rad or m), 0 without limits."""
        return self._worst("limit excess", max, 0.0)

    @property
    def collision_clearance(self) -> float:
        """The smallest distance minus its required one (m), NaN without distances kept."""
        return self._worst("clearance", min, math.nan)

    @property
    def task_error(self) -> float:
        """The largest goal task error (m or rad), NaN without joints."""
        return max(self.task_errors.values(), default=0.0) if self.q is not None else math.nan

    def as_dict(self) -> dict:
        """JSON-friendly dictionary (a whole-body problem's result with its task errors and measures)."""
        values = {"method": self.method, "success": self.success, "reason": self.reason,
                  "q": self.q, "time_s": self.time_s,
                  "iterations": self.iterations}
        if self.task_errors:
            values.update(task_errors=self.task_errors, contact_drift=self.contact_drift,
                          com_margin=self.com_margin, limit_excess=self.limit_excess,
                          collision_clearance=self.collision_clearance, unsupported=list(self.unsupported),
                          diagnosis=None if self.diagnosis is None else self.diagnosis.as_dict())
        else:
            values.update(position_error=self.position_error, rotation_error=self.rotation_error,
                          position_error_xyz=self.position_error_xyz,
                          rotation_error_xyz=self.rotation_error_xyz)
            if self.diagnosis is not None:
                values["diagnosis"] = self.diagnosis.as_dict()
        return json_plain(values)
