"""Small validators shared by the public API: each returns the clean value or raises a typed
:class:`wbik.errors.WbikError` whose message gives the value and what is allowed.

- :func:`check_budget` -- a time budget such as ``timeout_s``: a finite number > 0 (seconds).
- :func:`check_positive_finite` -- any positive finite setting (tolerances, ...).
- :func:`check_count` -- a count such as ``max_iterations``: an integer >= 1 (bools refused).
- :func:`check_nonnegative_finite` -- a setting such as a damping: a finite number >= 0.
- :func:`check_gain` -- a gain in (0, 1].
- :func:`numeric_array` -- an array of real numbers (no strings, bools, complex, objects, ragged
  lists), finite, of a given shape.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from wbik.errors import InvalidBudgetError
from wbik.errors import InvalidSettingError
from wbik.errors import WbikError


def _real_number(name: str, value, error: type[WbikError], unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{name} must be a finite number > 0{unit}, got {_short(value)} "
                    f"({type(value).__name__}); allowed range: 0 < value < inf")
    return float(value)


def check_positive_finite(name: str, value, error: type[WbikError] = InvalidSettingError,
                          unit: str = "") -> float:
    """``value`` as a float if it is a real number, finite and > 0; else ``error`` naming ``name``."""
    suffix = f" ({unit})" if unit else ""
    number = _real_number(name, value, error, suffix)
    if not math.isfinite(number) or number <= 0.0:
        raise error(f"{name} must be a finite number > 0{suffix}, got {value!r}; allowed range: "
                    "0 < value < inf")
    return number


def check_budget(name: str, value) -> float:
    """A time budget in seconds (e.g. ``timeout_s``): a finite number > 0, else InvalidBudgetError.

    >>> check_budget("timeout_s", 0.005)
    0.005
    """
    return check_positive_finite(name, value, InvalidBudgetError, unit="s")


def check_count(name: str, value, error: type[WbikError] = InvalidSettingError) -> int:
    """``value`` as an int if it is an integer >= 1 (bools refused); else ``error`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise error(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def check_nonnegative_finite(name: str, value, error: type[WbikError] = InvalidSettingError) -> float:
    """``float(value)`` if it is finite and >= 0; else ``error`` naming ``name``."""
    number = float(value)
    if not (math.isfinite(number) and number >= 0.0):
        raise error(f"{name} must be a finite number >= 0, got {value!r}")
    return number


def check_gain(name: str, value, error: type[WbikError] = InvalidSettingError) -> float:
    """``float(value)`` if it is in (0, 1]; else ``error`` naming ``name``."""
    number = float(value)
    if not 0.0 < number <= 1.0:
        raise error(f"{name} must be in (0, 1], got {value!r}")
    return number


def check_seed(seed) -> int | None:
    """``seed`` (an integer >= 0, bools refused, or None) unchanged; InvalidSettingError otherwise."""
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0):
        raise InvalidSettingError(f"seed must be an integer >= 0 or None, got {seed!r}")
    return seed


def numeric_array(value, what: str, error: type[WbikError], shape: tuple[int, ...] | None = None,
                  max_abs: float | None = None) -> np.ndarray:
    """``value`` as a float array of real numbers, or ``error`` saying what is wrong.

    Refuses strings, bytes, mappings, None, bools, complex and object values and ragged nested
    lists (numpy would otherwise coerce or crash on them), NaN/inf, a shape other than ``shape``
    and entries larger than ``max_abs`` in magnitude.
    """
    if value is None or isinstance(value, str | bytes | dict | set | frozenset):
        raise error(f"{what} must be numbers, got {type(value).__name__} {_short(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise error(f"{what} must be a flat list or array of numbers with rows of equal length, got "
                    f"{_short(value)} ({exc})") from None
    if raw.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers", "O": "Python objects (ragged or mixed)",
                "U": "strings", "S": "bytes", "M": "datetimes", "m": "timedeltas"}.get(raw.dtype.kind,
                                                                                      str(raw.dtype))
        raise error(f"{what} must be real numbers, got {kind}: {_short(value)}")
    array = raw.astype(float)
    if shape is not None and array.shape != shape:
        raise error(f"{what} must have shape {shape}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise error(f"{what} contains NaN or inf: {array.tolist()}")
    if max_abs is not None and array.size and float(np.max(np.abs(array))) > max_abs:
        raise error(f"{what} has an entry of magnitude {float(np.max(np.abs(array))):.3g}; allowed: "
                    f"|value| <= {max_abs:g} (SI units: metres, radians)")
    return array


def finite_vector(value, size: int, what: str, error: type[WbikError]) -> np.ndarray:
    """``value`` flattened into a float vector of ``size`` finite numbers, else ``error``: "``what``
    must be ``size`` finite numbers"."""
    try:
        array = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        array = None
    if array is None or array.shape != (size,) or not np.all(np.isfinite(array)):
        raise error(f"{what} must be {size} finite numbers, got {_short(value)}")
    return array


def _short(value, limit: int = 80) -> str:
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a hostile __repr__ must not hide the real error
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[:limit - 3] + "..."
