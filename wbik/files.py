"""Atomic file writes (a temporary file per process next to the destination, renamed into place: a
reader sees the old file or the new one, never a partial write), the plain values JSON takes, and the
reading of YAML/JSON/TOML data files."""

from __future__ import annotations

import json
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


def read_data_file(path: Path, error: type[Exception], kind: str, shape: str, missing: str = ""):
    """The parsed content of a YAML, JSON or TOML text file (by its suffix; YAML otherwise), or ``error``
    saying what is wrong: ``kind`` names the file ("scenario"), ``shape`` what its content must be
    ("a scenario is a mapping ..."), ``missing`` ends a missing file's message."""
    if path.is_dir():
        raise error(f"{kind} file {str(path)!r} is a directory; pass a YAML/JSON/TOML {kind} file")
    if not path.is_file():
        raise error(f"{kind} file {str(path)!r} does not exist{missing}")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text (byte {exc.start}: {exc.reason}); a {kind} file is "
                    "YAML/JSON/TOML text") from None
    except OSError as exc:
        raise error(f"cannot read {kind} file {str(path)!r}: {exc.strerror}") from None
    import tomllib  # on first use: ``import wbik`` stays quick

    import yaml

    suffix = path.suffix.lower()
    parse = {".json": json.loads, ".toml": tomllib.loads}.get(suffix, yaml.safe_load)
    try:
        data = parse(text) if text.strip() else None
    except Exception as exc:  # yaml, json and tomllib raise several types
        raise error(f"{path}: not valid {suffix.lstrip('.').upper() or 'YAML'}: {exc}") from None
    if data is None:
        raise error(f"{path}: the file is empty (or only comments or null); {shape}")
    return data
