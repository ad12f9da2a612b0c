"""Balance: the centre of mass over the support polygon, shrunk by a margin."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from wbik.kernels.twins import chosen, compiled_twin
from wbik.qp.constraint import SLACK, InequalityConstraint, Measure, StartViolation
from wbik.qp.kinematics import Kinematics
from wbik.qp.rows import InequalityRows, RowLabel, StackedRows
from wbik.qp.support_polygon import (
    DegenerateSupport,
    SupportPolygon,
    feet_support_polygon,
    feet_support_region,
)

_POLYGON_ROWS = compiled_twin("qp_rows", "polygon_rows")
"""The compiled twin of CoMInSupportPolygon.inequality (None where it is not built)."""


class CoMInSupportPolygon(InequalityConstraint):
    """The CoM's ground projection inside the support polygon shrunk by ``margin`` (m), linearised:
    N (c_xy + J_com,xy dq) <= d - margin - safety per edge. The polygon is ``polygon``, or that of ``soles``
    (``robot.soles``) at the start and, for the measure, at the configuration judged."""

    label_kind = "support polygon"
    quantity = "CoM margin"

    def __init__(self, polygon: SupportPolygon | None = None, margin: float = 0.0, safety: float = 2e-6,
                 *, soles: Mapping[str, np.ndarray] | None = None):
        if margin < 0:
            raise ValueError(f"the margin must be >= 0, got {margin}")
        if (polygon is None) == (soles is None):
            raise ValueError("CoMInSupportPolygon takes a polygon or the soles that make it, not both")
        self.soles = None if soles is None else dict(soles)
        self.margin, self.safety = float(margin), float(safety)
        self.name = f"CoM in support polygon (margin {margin * 1e3:g} mm)"
        self._version, self._projected = -1, np.zeros(0)
        if polygon is not None:
            self._use(polygon)

    def _use(self, polygon: SupportPolygon) -> None:
        self.polygon = polygon
        self.normals, self.offsets = polygon.halfplanes(self.margin + self.safety)
        self._version, self._projected = -1, np.zeros(len(self.offsets))

    def start(self, kinematics: Kinematics) -> None:
        if self.soles is not None:
            self._use(feet_support_polygon(kinematics, self.soles, list(self.soles)))

    def projected(self, kinematics: Kinematics) -> np.ndarray:
        """N c_xy at the kinematics' q (once per configuration: the rows and the margin share it)."""
        if self._version != kinematics.version:
            self._projected = self.normals.dot(kinematics.com()[:2])
            self._version = kinematics.version
        return self._projected

    def inequality(self, kinematics: Kinematics) -> InequalityRows:
        return InequalityRows(self.normals.dot(kinematics.com_jacobian()[:2]),
                              self.offsets - self.projected(kinematics))

    def compiled_rows(self, kinematics: Kinematics, rows: StackedRows) -> Callable[[], bool] | None:
        """``inequality``'s G and h written by one kernel call (False once the polygon's edges changed)."""
        kernel = chosen(None, _POLYGON_ROWS, "qp_rows")
        count = len(self.offsets) if hasattr(self, "offsets") else -1
        if kernel is None or rows.matrix.shape[0] != count:
            return None
        G, h = rows.matrix, rows.upper

        def write() -> bool:
            if len(self.offsets) != count:
                return False
            kernel(self.normals, self.offsets, *kinematics.com_and_jacobian(), G, h)
            return True

        return write

    def labels(self, kinematics: Kinematics, rows) -> list[RowLabel]:
        inside = self.polygon.offsets - self.projected(kinematics)
        return [self.label(self.polygon.edge_name(index), "", float(distance), self.margin, "m")
                for index, distance in enumerate(inside.tolist())]

    def com_margin(self, kinematics: Kinematics) -> float:
        """Distance from the CoM projection to the polygon's boundary (m, positive inside)."""
        inside = (self.polygon.offsets - self.projected(kinematics)).tolist()
        nearest = min(inside)  # (Python's min on a few floats: a fifth of ndarray.min's call)
        return nearest if not math.isnan(sum(inside)) else float(np.min(inside))  # (NumPy's NaN)

    def violation(self, kinematics: Kinematics) -> float:
        return max(self.margin - self.com_margin(kinematics), 0.0)

    def measure(self, kinematics: Kinematics, tolerances) -> Measure:
        region = self.polygon if self.soles is None else feet_support_region(kinematics, self.soles,
                                                                             list(self.soles))
        value = region.margin_of(kinematics.com()[:2])
        if isinstance(region, DegenerateSupport):
            shape = "a segment" if len(region.vertices) == 2 else "a point"
            return Measure(self.name, self.quantity, value, "m", False,
                           f"support polygon is degenerate (the support spans no area: {shape}), CoM "
                           f"{-value * 1e3:.3g} mm from it")
        return Measure(self.name, self.quantity, value, "m", value >= self.margin - SLACK,
                       f"CoM margin {value * 1e3:.3g} mm < {self.margin * 1e3:g} mm")

    def start_violations(self, kinematics: Kinematics, q0: np.ndarray) -> list[StartViolation]:
        if self.violation(kinematics) <= SLACK:
            return []
        value = self.com_margin(kinematics)
        return [self.start_violation(self.name, value, self.margin, "m",
                                     f"CoM {value * 1e3:.3g} mm inside the support polygon < margin "
                                     f"{self.margin * 1e3:g} mm")]

    def row_text(self, label: RowLabel) -> str:
        return (f"CoM {label.value * 1e3:.3g} mm inside the edge {label.subject} "
                f"(margin {label.bound * 1e3:g} mm)")

    def blocker_text(self, label: RowLabel) -> str:
        return (f"CoM {label.value * 1e3:.3g} mm inside the edge {label.subject} of the support polygon "
                f"(margin {label.bound * 1e3:g} mm)")

    def advice(self, label: RowLabel) -> str:
        return (f"the CoM is held at the support polygon's edge {label.subject}: bring the target closer, "
                f"lower the margin ({label.bound * 1e3:g} mm) or widen the support")
