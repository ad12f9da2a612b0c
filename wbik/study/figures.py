"""The study's figures, drawn with matplotlib's Agg backend (no display needed).

- bars of the poses solved per method;
- box plots of |error| per axis over solved poses (log scale; exact zeros drawn at a floor);
- box plots of time per method, solved and unsolved poses side by side (log scale);
- a histogram of time per method (log bins).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from wbik.files import atomic_write_bytes
from wbik.study.metrics import AngleConvention  # noqa: E402
from wbik.study.metrics import axis_label  # noqa: E402

ZERO_FLOOR = 1e-18
"""Where exact zeros are drawn on logarithmic error axes."""


def _save(figure, path: Path) -> Path:
    def write(handle) -> None:
        figure.savefig(handle, format="png", dpi=110, bbox_inches="tight")

    atomic_write_bytes(path, write)
    plt.close(figure)
    return path


def solved_bars(summaries: dict[str, dict], title: str, path: Path) -> Path:
    labels = list(summaries)
    solved = [summaries[label]["solved"] for label in labels]
    unsolved = [summaries[label]["poses"] - summaries[label]["solved"] for label in labels]
    figure, axes = plt.subplots(figsize=(max(5.0, 0.9 * len(labels) + 2), 3.8))
    positions = np.arange(len(labels))
    axes.bar(positions, solved, color="tab:green", label="solved")
    axes.bar(positions, unsolved, bottom=solved, color="tab:red", alpha=0.6, label="not solved")
    for x, label in zip(positions, labels, strict=True):
        axes.text(x, summaries[label]["poses"], f"{summaries[label]['percent_solved']:.1f} %",
                  ha="center", va="bottom", fontsize=8)
    axes.set_xticks(positions, labels, rotation=30, ha="right")
    axes.set_ylabel("poses")
    axes.set_title(title)
    axes.legend(loc="lower right", fontsize=8)
    return _save(figure, path)


def error_boxplots(rows_by_method: dict[str, dict], axes_names: list[str], title: str, path: Path,
                   angles: AngleConvention | None = None) -> Path:
    columns = 3
    lines = -(-len(axes_names) // columns)
    labels = list(rows_by_method)
    figure, grid = plt.subplots(lines, columns, figsize=(4.2 * columns, 3.2 * lines), squeeze=False)
    for index, axis in enumerate(axes_names):
        subplot = grid[index // columns][index % columns]
        data = []
        for label in labels:
            rows = rows_by_method[label]
            values = np.abs(rows[f"err_{axis}"][rows["success"].astype(bool)])
            values = values[np.isfinite(values)]
            data.append(np.maximum(values, ZERO_FLOOR) if values.size else np.array([np.nan]))
        subplot.boxplot(data, showfliers=True, flierprops={"markersize": 2})
        subplot.set_yscale("log")
        subplot.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right", fontsize=7)
        subplot.set_title(f"|error| {axis_label(axis, angles)}", fontsize=9)
    for index in range(len(axes_names), lines * columns):
        grid[index // columns][index % columns].set_visible(False)
    figure.suptitle(f"{title} (solved poses; exact zeros drawn at {ZERO_FLOOR:g})", fontsize=10)
    figure.tight_layout()
    return _save(figure, path)


def time_boxplots(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    labels = list(rows_by_method)
    figure, axes = plt.subplots(figsize=(max(6.0, 1.1 * len(labels) + 2), 4.0))
    data, positions, colours = [], [], []
    for index, label in enumerate(labels):
        rows = rows_by_method[label]
        success = rows["success"].astype(bool)
        for offset, mask, colour in ((-0.18, success, "tab:green"), (0.18, ~success, "tab:red")):
            values = rows["time_s"][mask] * 1e3
            values = values[np.isfinite(values) & (values > 0)]
            if values.size:
                data.append(values)
                positions.append(index + 1 + offset)
                colours.append(colour)
    if data:
        boxes = axes.boxplot(data, positions=positions, widths=0.3, patch_artist=True, showfliers=True,
                             flierprops={"markersize": 2})
        for patch, colour in zip(boxes["boxes"], colours, strict=True):
            patch.set_facecolor(colour)
            patch.set_alpha(0.5)
    axes.set_yscale("log")
    axes.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right")
    axes.set_xlim(0.4, len(labels) + 0.6)
    axes.set_ylabel("time (ms)")
    axes.set_title(f"{title}: time per pose (green solved, red not solved)")
    return _save(figure, path)


def time_histogram(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    figure, axes = plt.subplots(figsize=(7.0, 4.0))
    all_times = np.concatenate([rows["time_s"] * 1e3 for rows in rows_by_method.values()])
    all_times = all_times[np.isfinite(all_times) & (all_times > 0)]
    if all_times.size:
        bins = np.logspace(np.log10(all_times.min()), np.log10(all_times.max()) + 1e-9, 50)
        for label, rows in rows_by_method.items():
            times = rows["time_s"] * 1e3
            times = times[np.isfinite(times) & (times > 0)]
            axes.hist(times, bins=bins, histtype="step", linewidth=1.4, label=label)
        axes.set_xscale("log")
        axes.legend(fontsize=8)
    axes.set_xlabel("time (ms)")
    axes.set_ylabel("poses")
    axes.set_title(f"{title}: distribution of time per pose")
    return _save(figure, path)
