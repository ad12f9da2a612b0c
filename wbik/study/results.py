"""Where a study's results live on disk (``runs/<study name>/``), written to a temporary name and renamed::

    study.json                              the definition that was run, with its fingerprint
    <case>/poses.npz                        q_true, positions, rotations (pose targets), q0
    <case>/chunks/<method>/chunk_00012.npz  raw rows of poses [12 * chunk_size, 13 * chunk_size)
    <case>/chunks/<method>/method.json      the method's definition those chunks were computed with
    <case>/chunks/<method>/throughput.npz   its throughput pass over the case (no columns: no batched path)
    <case>/not_applicable.json              {method label: why it does not apply}
    <case>/raw.csv, summary.csv, significance.csv, figures/*.png
    report.md, report.html
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from wbik.files import atomic_write_bytes, atomic_write_text

ROW_FIELDS = ("pose", "success", "reason", "time_s", "iterations", "position_error", "rotation_error")
"""Columns of every raw row before the per-axis errors and the joints."""


def write_json(path: Path, data) -> None:
    atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


def read_json(path: Path, default=None):
    return json.loads(path.read_text()) if path.is_file() else default


def case_dir(output: Path, case_name: str) -> Path:
    return output / case_name


def chunk_path(output: Path, case_name: str, label: str, chunk: int) -> Path:
    return case_dir(output, case_name) / "chunks" / label / f"chunk_{chunk:05d}.npz"


def throughput_path(output: Path, case_name: str, label: str) -> Path:
    """The columns of a method's throughput pass over a case (beside its chunks, forgotten with them)."""
    return case_dir(output, case_name) / "chunks" / label / "throughput.npz"


def write_chunk(path: Path, columns: dict[str, np.ndarray]) -> None:
    """One chunk of raw rows as a .npz of equal-length columns (strings as unicode arrays)."""
    atomic_write_bytes(path, lambda handle: np.savez(handle, **columns))


def read_chunk(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {key: data[key] for key in data.files}


def load_method_rows(output: Path, case_name: str, label: str,
                     chunk_count: int) -> dict[str, np.ndarray] | None:
    """The rows of one method, in pose order, from its chunk files (with its throughput pass's columns,
    where there is one); None if any chunk is missing."""
    paths = [chunk_path(output, case_name, label, chunk) for chunk in range(chunk_count)]
    if not all(path.is_file() for path in paths):
        return None
    parts = [read_chunk(path) for path in paths]
    rows = {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}
    throughput = throughput_path(output, case_name, label)
    return {**rows, **read_chunk(throughput)} if throughput.is_file() else rows


def write_csv(path: Path, header: list, rows: Iterable[list], lineterminator: str = "\n") -> None:
    """``header`` then ``rows`` as a CSV, streamed to a temporary file renamed into place."""
    def write(handle) -> None:
        text = io.TextIOWrapper(handle, encoding="utf-8", newline="")
        writer = csv.writer(text, lineterminator=lineterminator)
        writer.writerow(header)
        writer.writerows(rows)
        text.flush()
        text.detach()

    atomic_write_bytes(path, write)


def csv_cells(values) -> list:
    """A column's CSV cells: floats by ``repr`` (every digit), booleans and integers as integers, text."""
    values = np.asarray(values)
    if values.dtype.kind == "f":
        return [repr(value) for value in values.tolist()]
    return values.astype(int).tolist() if values.dtype.kind in "biu" else [str(v) for v in values.tolist()]


def method_csv_rows(label: str, rows: dict[str, np.ndarray], keys: Iterable[str], index: str = "pose",
                    joints: bool = True) -> Iterable[list]:
    """One method's CSV rows: ``rows[index]``, the label, the ``keys``' cells, then (``joints``) q's."""
    count = len(rows[index])
    columns = [rows[index], [label] * count, *(rows[key] for key in keys), *(rows["q"].T if joints else ())]
    return zip(*(csv_cells(column) for column in columns), strict=True)


def write_raw_csv(path: Path, rows_by_method: dict[str, dict[str, np.ndarray]],
                  joint_names: list[str]) -> None:
    """Every (pose, method) row in one CSV: ROW_FIELDS, method, err_* columns, q_<joint> columns."""
    if not rows_by_method:
        atomic_write_text(path, "")
        return
    keys = [*ROW_FIELDS[1:], *(key for key in next(iter(rows_by_method.values())) if key.startswith("err_"))]
    write_csv(path, ["pose", "method", *keys, *(f"q_{name}" for name in joint_names)],
              (row for label, rows in rows_by_method.items() for row in method_csv_rows(label, rows, keys)),
              lineterminator="\r\n")


def read_raw_csv(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """A merged raw.csv back into {method: {column: array}} (for checks and notebooks; no pandas)."""
    with open(path, newline="", encoding="utf-8") as handle:
        grouped: dict[str, list[dict]] = {}
        for row in csv.DictReader(handle):
            grouped.setdefault(row["method"], []).append(row)
    types = {"reason": str, "pose": int, "iterations": int, "success": int}

    def column(key: str, rows: list[dict]) -> np.ndarray:
        values = np.array([row[key] for row in rows], dtype=types.get(key, float))
        return values.astype(bool) if key == "success" else values

    return {label: {key: column(key, rows) for key in rows[0] if key != "method"}
            for label, rows in grouped.items()}
