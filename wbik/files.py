"""Atomic file writes (a temporary file per process next to the destination, renamed into place: a
reader sees the old file or the new one, never a partial write) and the plain values JSON takes."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

import numpy as np


def json_plain(value, finite: bool = False):
    """``value`` with NumPy arrays and scalars made plain Python, tuples lists and keys strings, at any
    depth; with ``finite``, NaN and infinities None."""
    if isinstance(value, dict):
        return {str(k): json_plain(v, finite) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_plain(v, finite) for v in value]
    if isinstance(value, np.ndarray):
        return json_plain(value.tolist(), finite)
    if isinstance(value, np.generic):
        value = value.item()
    if finite and isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def atomic_write_bytes(path: Path, writer: Callable[[BinaryIO], object]) -> None:
    """Call ``writer(handle)`` on a temporary file next to ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(temporary, "wb") as handle:
            writer(handle)
            handle.flush()
            os.fsync(handle.fileno())
        temporary.replace(path)
    except BaseException:
        temporary.unlink(missing_ok=True)  # a failed or interrupted write leaves nothing behind
        raise


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, lambda handle: handle.write(text.encode()))
