"""Numbers as arrays: :func:`numeric_array` and :func:`finite_vector` turn what a caller gives into
float arrays of a given shape, or raise a typed :class:`wbik.errors.WbikError` saying what is wrong
(a value's type and range: the schema language, :mod:`wbik.schema`)."""

from __future__ import annotations

import numpy as np

from wbik.errors import WbikError


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
