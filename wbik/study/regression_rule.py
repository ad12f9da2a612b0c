"""The regression gate's rule, a study file's ``regression:`` block (applied by :mod:`wbik.study.compare`)::

    regression: {success_level: 0.05, time_rise: 1.2}     # the defaults
"""

from __future__ import annotations

from dataclasses import dataclass

from wbik.schema import Constant, Either, Key, Map, Number, dataclass_default


@dataclass(frozen=True)
class RegressionRule:
    """When ``--compare-to OLD`` calls a method worse: ``success_level``, the level of McNemar's test of a
    wall-clock method's success; ``time_rise``, the factor the interval of the time ratio must exceed."""

    success_level: float = 0.05
    time_rise: float | None = 1.2


def regression_schema() -> Map:
    """``regression:`` {success_level, time_rise}, defaults those of :class:`RegressionRule`."""
    level = Number(gt=0, lt=1, strings=True, as_float=True, what="a test level between 0 and 1 (e.g. 0.05)")
    rise = Either(Number(ge=1, strings=True, as_float=True, what="a factor >= 1"),
                  Constant("off", False, None), what="a factor >= 1 (e.g. 1.2) or off")
    return Map({"success_level": Key(level, dataclass_default(RegressionRule, "success_level"),
                                     doc="the level of the paired test of a wall-clock method's success"),
                "time_rise": Key(rise, dataclass_default(RegressionRule, "time_rise"),
                                 doc="the factor the per-target time ratio's interval must exceed")},
               nullable=True, what="a mapping {success_level: 0.05, time_rise: 1.2}")


def regression_rule(raw: dict) -> RegressionRule:
    """``regression:`` as checked by :func:`regression_schema` (time_rise off, false or null: None)."""
    rise = raw["time_rise"]
    return RegressionRule(success_level=raw["success_level"],
                          time_rise=None if rise in (None, False, "off") else float(rise))
