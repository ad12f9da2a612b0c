"""Numbers as arrays: what a caller gives as a float array of a given shape, or a typed
:class:`wbik.errors.WbikError` saying what is wrong."""

from __future__ import annotations

import numpy as np

from wbik.errors import WbikError
from wbik.schema import short


def numeric_array(value, what: str, error: type[WbikError], shape: tuple[int, ...] | None = None,
                  max_abs: float | None = None) -> np.ndarray:
    """``value`` as a float array of real numbers, or ``error``: strings, mappings, None, bools, complex,
    objects and ragged lists (which numpy would coerce or crash on), NaN/inf, a shape other than
    ``shape``, entries beyond ``max_abs`` in magnitude."""
    if value is None or isinstance(value, str | bytes | dict | set | frozenset):
        raise error(f"{what} must be numbers, got {type(value).__name__} {short(value, 80)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise error(f"{what} must be a flat list or array of numbers with rows of equal length, got "
                    f"{short(value, 80)} ({exc})") from None
    if raw.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers", "O": "Python objects (ragged or mixed)",
                "U": "strings", "S": "bytes", "M": "datetimes", "m": "timedeltas"}.get(raw.dtype.kind,
                                                                                      str(raw.dtype))
        raise error(f"{what} must be real numbers, got {kind}: {short(value, 80)}")
    array = raw.astype(float)
    if shape is not None and array.shape != shape:
        raise error(f"{what} must have shape {shape}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise error(f"{what} contains NaN or inf: {array.tolist()}")
    if max_abs is not None and array.size and float(np.max(np.abs(array))) > max_abs:
        raise error(f"{what} has an entry of magnitude {float(np.max(np.abs(array))):.3g}; allowed: "
                    f"|value| <= {max_abs:g} (SI units: metres, radians)")
    return array


def finite_vector(value, size: int, what: str, error: type[WbikError], positive: bool = False) -> np.ndarray:
    """``value`` flattened to ``size`` finite numbers (> 0 if ``positive``), else ``error``."""
    try:
        array = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        array = np.array([])
    if (isinstance(value, str) or array.shape != (size,) or not np.all(np.isfinite(array))
            or (positive and np.any(array <= 0))):
        raise error(f"{what} must be {size} {'positive ' * positive}finite numbers, got {short(value, 80)}")
    return array
