"""The study's figures (matplotlib, Agg backend); a method has the same colour in every figure of a case
(:func:`colours`)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from wbik.files import atomic_write_bytes  # noqa: E402
from wbik.study.metrics import AngleConvention, axis_label  # noqa: E402

ZERO_FLOOR = 1e-18
"""Where exact zeros are drawn on logarithmic error axes."""


def save(figure, path: Path) -> Path:
    """``figure`` as a PNG at ``path``, trimmed to what it draws (no layout engine), then closed."""
    def write(handle) -> None:
        figure.savefig(handle, format="png", dpi=110, bbox_inches="tight")

    atomic_write_bytes(path, write)
    plt.close(figure)
    return path


def _axis_grid(count: int, height: float) -> tuple[plt.Figure, list]:
    """(figure, its ``count`` subplots), three to a line, each 4.2 x ``height`` inches, the rest hidden."""
    columns = 3
    lines = -(-count // columns)
    figure, grid = plt.subplots(lines, columns, figsize=(4.2 * columns, height * lines), squeeze=False,
                                gridspec_kw={"hspace": 1.1 / height, "wspace": 0.25,
                                             "top": 1 - 0.6 / (height * lines)})
    cells = [cell for line in grid for cell in line]
    for cell in cells[count:]:
        cell.set_visible(False)
    return figure, cells[:count]


def _solved_errors(rows: dict, axis: str) -> np.ndarray:
    """|error| on ``axis`` (the ``err_<axis>`` column) of the solved poses, finite values only."""
    magnitude = np.abs(rows[f"err_{axis}"][rows["success"].astype(bool)])
    return magnitude[np.isfinite(magnitude)]


def positive(values: np.ndarray) -> np.ndarray:
    """The finite values > 0 of ``values`` (what a logarithmic axis draws)."""
    return values[np.isfinite(values) & (values > 0)]


def boxes(axes, samples: list[np.ndarray], fill: list | None = None, alpha: float = 0.5, **options) -> dict:
    """Box plots of ``samples`` (small fliers, an empty sample as NaN); ``fill``: a colour per box."""
    drawn = axes.boxplot([values if values.size else np.array([np.nan]) for values in samples],
                         showfliers=True, flierprops={"markersize": 2}, patch_artist=bool(fill), **options)
    for patch, colour in zip(drawn["boxes"], fill or [], strict=fill is not None):
        patch.set_facecolor(colour)
        patch.set_alpha(alpha)
    return drawn


def colours(labels) -> dict[str, tuple]:
    """A colour per method label, in order: tab20's ten darker shades, then its ten lighter ones."""
    palette = plt.get_cmap("tab20").colors
    order = [*palette[0::2], *palette[1::2]]
    return {label: order[index % len(order)] for index, label in enumerate(labels)}


def _bars(labels: list[str], values: np.ndarray, colour: dict, smallest_width: float) -> tuple:
    """(figure, axes, positions) of a bar per label in its colour, the labels under the bars."""
    figure, axes = plt.subplots(figsize=(max(smallest_width, 0.9 * len(labels) + 2), 4.0))
    positions = np.arange(len(labels))
    axes.bar(positions, values, color=[colour[label] for label in labels], alpha=0.85)
    axes.set_xticks(positions, labels, rotation=30, ha="right")
    return figure, axes, positions


def solved_bars(summaries: dict[str, dict], title: str, path: Path) -> Path:
    """% solved per method, with its 95 % interval (``percent_solved_ci_low``/``_high``) as a whisker
    and as text under the figure's value."""
    labels = list(summaries)
    percent = np.array([summaries[label]["percent_solved"] for label in labels], dtype=float)
    low = np.array([summaries[label].get("percent_solved_ci_low", np.nan) for label in labels], dtype=float)
    high = np.array([summaries[label].get("percent_solved_ci_high", np.nan) for label in labels], dtype=float)
    figure, axes, positions = _bars(labels, percent, colours(labels), 5.0)
    whiskers = np.nan_to_num(np.vstack([percent - low, high - percent]), nan=0.0)
    axes.errorbar(positions, percent, yerr=np.maximum(whiskers, 0.0), fmt="none", ecolor="black",
                  elinewidth=1.2, capsize=4)
    for x, value, lo, hi in zip(positions, percent, low, high, strict=True):
        interval = f"\n[{lo:.1f}, {hi:.1f}]" if np.isfinite(lo) else ""
        top = max(value, hi) if np.isfinite(hi) else value
        axes.text(x, min(top, 100.0) + 1.5, f"{value:.1f} %{interval}", ha="center", va="bottom", fontsize=7)
    axes.set_ylim(0, 118)
    axes.set_yticks(np.arange(0, 101, 20))
    axes.set_ylabel("% solved (95 % interval)")
    axes.set_title(f"{title}: poses solved")
    return save(figure, path)


def throughput_bars(summaries: dict[str, dict], title: str, path: Path) -> Path:
    """Poses per second of solve_many over the case (log scale) of the methods that have one
    (``throughput_poses_per_s`` finite): a pale bar for one process, a full one for every core, the rates
    and the share solved written above."""
    labels = [label for label, s in summaries.items() if np.isfinite(s.get("throughput_poses_per_s", np.nan))]
    one = np.array([summaries[label]["throughput_poses_per_s"] for label in labels], dtype=float)
    cores = np.array([summaries[label].get("throughput_cores_poses_per_s", np.nan) for label in labels],
                     dtype=float)
    colour = colours(summaries)
    figure, axes = plt.subplots(figsize=(max(4.0, 1.3 * len(labels) + 2), 4.0))
    positions = np.arange(len(labels))
    axes.bar(positions - 0.2, one, width=0.4, color=[colour[label] for label in labels], alpha=0.4,
             label="one process")
    axes.bar(positions + 0.2, cores, width=0.4, color=[colour[label] for label in labels], alpha=0.9,
             label="every core")
    axes.set_xticks(positions, labels, rotation=30, ha="right")
    for x, label, slow, fast in zip(positions, labels, one, cores, strict=True):
        solved = summaries[label]["throughput_percent_solved"]
        axes.text(x, np.nanmax([slow, fast]) * 1.15, f"{slow:.3g} / {fast:.3g} /s\n{solved:.1f} % solved",
                  ha="center", va="bottom", fontsize=7)
    axes.set_yscale("log")
    finite = np.concatenate([one, cores])
    finite = finite[np.isfinite(finite)]
    if finite.size:
        axes.set_ylim(finite.min() / 10, finite.max() * 10)
    axes.set_ylabel("throughput (poses/s, solve_many over the case)")
    axes.legend(fontsize=7, loc="lower right")
    axes.set_title(f"{title}: throughput of batched methods")
    return save(figure, path)


def error_histograms(rows_by_method: dict[str, dict], axes_names: list[str], title: str, path: Path,
                     angles: AngleConvention | None = None) -> Path:
    """Step histograms of log10 |error| per axis and method (solved poses), exact zeros at ZERO_FLOOR."""
    labels = list(rows_by_method)
    colour = colours(labels)
    figure, cells = _axis_grid(len(axes_names), 3.0)
    for subplot, axis in zip(cells, axes_names, strict=True):
        magnitudes = {label: _solved_errors(rows, axis) for label, rows in rows_by_method.items()}
        values = {label: np.log10(np.maximum(m, ZERO_FLOOR)) for label, m in magnitudes.items() if m.size}
        if values:
            everything = np.concatenate(list(values.values()))
            bins = np.linspace(everything.min(), everything.max() + 1e-9, 40)
            for label, logs in values.items():
                subplot.hist(logs, bins=bins, histtype="step", linewidth=1.2, color=colour[label],
                             label=label)
        subplot.set_xlabel(f"log10 |error| {axis_label(axis, angles)}", fontsize=8)
        subplot.set_ylabel("poses", fontsize=8)
        subplot.tick_params(labelsize=7)
    handles, names = cells[0].get_legend_handles_labels()
    if handles:
        figure.legend(handles, names, loc="upper center", ncol=min(6, len(names)), fontsize=7,
                      bbox_to_anchor=(0.5, 1.0))
    figure.suptitle(f"{title}: distribution of |error| (solved poses; zeros at {ZERO_FLOOR:g})", fontsize=10,
                    y=1.0 + 0.2 / figure.get_figheight(), va="bottom")
    return save(figure, path)


def time_ecdf(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    """Two ECDFs of time per method (log time axis): the share of calls returned within t,
    #{time <= t} / n, and the share of poses solved within t, #{solved, time <= t} / n."""
    labels = list(rows_by_method)
    colour = colours(labels)
    figure, (returned, solved) = plt.subplots(1, 2, figsize=(12.0, 4.2), sharex=True,
                                              gridspec_kw={"top": 0.82})
    for label in labels:
        rows = rows_by_method[label]
        times = rows["time_s"] * 1e3
        finite = np.isfinite(times) & (times > 0)
        if not finite.any():
            continue
        count = times.size
        order = np.sort(times[finite])
        returned.step(order, np.arange(1, order.size + 1) / count, where="post", color=colour[label],
                      linewidth=1.3, label=label)
        success = rows["success"].astype(bool) & finite
        won = np.sort(times[success])
        if won.size:
            solved.step(won, 100.0 * np.arange(1, won.size + 1) / count, where="post", color=colour[label],
                        linewidth=1.3, label=label)
    for axes, ylabel, heading in ((returned, "share of calls returned", "calls returned within t"),
                                  (solved, "% of poses solved", "poses solved within t")):
        axes.set_xscale("log")
        axes.set_xlabel("time t (ms)")
        axes.set_ylabel(ylabel)
        axes.set_title(heading, fontsize=10)
        axes.grid(True, which="both", alpha=0.25)
    handles, names = returned.get_legend_handles_labels()
    figure.suptitle(f"{title}: time per call (ECDF)", fontsize=11)
    if handles:
        solved.legend(handles, names, fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    return save(figure, path)


BUDGET_STYLES = {"iterations": "-", "wall": "--", "none": ":"}
"""Line style of a budget curve by the method's budget kind."""


def budget_curves(curves: dict, kinds: dict[str, str], title: str, path: Path) -> Path:
    """% solved against the budget (ms, log axis) per method with its 95 % (Wilson) band; ``kinds``
    (label -> "iterations", "wall" or "none") sets the line style."""
    labels = list(curves)
    colour = colours(labels)
    figure, axes = plt.subplots(figsize=(9.0, 5.0))
    for label in labels:
        curve = curves[label]
        low, high = curve.interval()
        style = BUDGET_STYLES.get(kinds.get(label, "wall"), "--")
        axes.plot(curve.budgets_ms, curve.percent, style, marker="o" if style != ":" else None, markersize=3,
                  color=colour[label], linewidth=1.4, label=f"{label} ({kinds.get(label, 'wall')})")
        axes.fill_between(curve.budgets_ms, low, high, color=colour[label], alpha=0.12, linewidth=0)
    axes.set_xscale("log")
    axes.set_ylim(-2, 102)
    axes.set_xlabel("budget per solve (ms): the iterations that cost that long for 'iterations', "
                    "wall clock for 'wall'")
    axes.set_ylabel("% solved (95 % band)")
    axes.grid(True, which="both", alpha=0.25)
    if labels:
        first = next(iter(curves.values()))
        axes.set_xticks(first.budgets_ms, [f"{value:g}" for value in first.budgets_ms])
        axes.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        axes.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
        axes.set_title(f"{title}: success versus budget ({first.poses} poses per point)")
    return save(figure, path)


def error_boxplots(rows_by_method: dict[str, dict], axes_names: list[str], title: str, path: Path,
                   angles: AngleConvention | None = None) -> Path:
    labels = list(rows_by_method)
    figure, cells = _axis_grid(len(axes_names), 3.2)
    for subplot, axis in zip(cells, axes_names, strict=True):
        boxes(subplot, [np.maximum(_solved_errors(rows, axis), ZERO_FLOOR)
              for rows in rows_by_method.values()])
        subplot.set_yscale("log")
        subplot.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right", fontsize=7)
        subplot.set_title(f"|error| {axis_label(axis, angles)}", fontsize=9)
    figure.suptitle(f"{title} (solved poses; exact zeros drawn at {ZERO_FLOOR:g})", fontsize=10)
    return save(figure, path)


def time_boxplots(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    labels = list(rows_by_method)
    figure, axes = plt.subplots(figsize=(max(6.0, 1.1 * len(labels) + 2), 4.0))
    data, positions, colours = [], [], []
    for index, label in enumerate(labels):
        rows = rows_by_method[label]
        success = rows["success"].astype(bool)
        for offset, mask, colour in ((-0.18, success, "tab:green"), (0.18, ~success, "tab:red")):
            values = positive(rows["time_s"][mask] * 1e3)
            if values.size:
                data.append(values)
                positions.append(index + 1 + offset)
                colours.append(colour)
    if data:
        boxes(axes, data, colours, positions=positions, widths=0.3)
    axes.set_yscale("log")
    axes.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right")
    axes.set_xlim(0.4, len(labels) + 0.6)
    axes.set_ylabel("time (ms)")
    axes.set_title(f"{title}: time per pose (green solved, red not solved)")
    return save(figure, path)


def time_histogram(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    figure, axes = plt.subplots(figsize=(7.0, 4.0))
    colour = colours(rows_by_method)
    all_times = positive(np.concatenate([rows["time_s"] * 1e3 for rows in rows_by_method.values()]))
    if all_times.size:
        bins = np.logspace(np.log10(all_times.min()), np.log10(all_times.max()) + 1e-9, 50)
        for label, rows in rows_by_method.items():
            axes.hist(positive(rows["time_s"] * 1e3), bins=bins, histtype="step", linewidth=1.4, label=label,
                      color=colour[label])
        axes.set_xscale("log")
        axes.legend(fontsize=8)
    axes.set_xlabel("time (ms)")
    axes.set_ylabel("poses")
    axes.set_title(f"{title}: distribution of time per pose")
    return save(figure, path)
