"""Solution coverage: which of a pose's solutions a method finds, against a complete closed form
(:mod:`wbik.study.closed_form_branches`). Columns: ``start_distance`` |q - q0|, ``same_branch`` (1: the
branch nearest the start, 0: another), ``branch`` (the in-limit branch it equals), ``branches_in_limits``;
on the first ``restart_targets`` poses, solved again from ``restarts`` starts, ``restart_solved``,
``restart_branches`` and ``restart_others`` (solutions equal to no branch). Equal: within
``branch_tolerance`` on every joint, revolute modulo 2 pi; -1: unknown or none."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from wbik.geometry import joint_gap
from wbik.robot import Chain
from wbik.study.blocks import Block, fmt
from wbik.study.closed_form_branches import (
    ClosedFormBranches,
    branch_index,
    complete_closed_form,
    in_limit_branches,
)
from wbik.study.statistics import P95, finite_statistic
from wbik.study.target_parameters import Parameter, integer, number

COVERAGE_PARAMETERS = {
    "restarts": Parameter(8, "an integer >= 0 (starts per sampled pose)", integer(0, 1000),
                          "random starts per pose of the restart sample"),
    "restart_targets": Parameter(20, "an integer >= 0 (poses)", integer(0),
                                 "how many poses (the case's first) are solved again from the random starts"),
    "branch_tolerance": Parameter(1e-3, "a number in (0, 0.5] (rad or m)", number(0, 0.5, low_open=True),
                                  "largest joint difference (revolute modulo 2 pi) of two equal solutions"),
}
RESTART_STREAM = 0x5EED  # the restarts' starts: default_rng([seed, RESTART_STREAM, pose])
_LOCAL = threading.local()


def closed_form_of(chain: Chain) -> ClosedFormBranches | str:
    """:func:`complete_closed_form` of the chain, built once per thread."""
    cache = _LOCAL.__dict__.setdefault("forms", {})
    if (key := (id(chain.robot), chain.name)) not in cache:
        cache[key] = complete_closed_form(chain)
    return cache[key]


def restart_starts(chain: Chain, seed: int, pose: int, count: int) -> np.ndarray:
    """(count, n) starts uniform inside the limits for the restarts of pose ``pose``."""
    return chain.random(np.random.default_rng([seed, RESTART_STREAM, pose]), count)


def coverage_columns(chain: Chain, columns: dict[str, np.ndarray], q0: np.ndarray, positions: np.ndarray,
                     rotations: np.ndarray, first_pose: int, seed: int, parameters: dict,
                     solve: Callable) -> dict[str, np.ndarray]:
    """A chunk's coverage columns from the method's rows ``columns``; ``solve(target, q0)``: the method."""
    import pinocchio as pin

    count = len(q0)
    q, success = columns["q"], columns["success"].astype(bool)
    found = np.all(np.isfinite(q), axis=1)
    distance = np.full(count, np.nan)
    distance[found] = np.linalg.norm(q[found] - q0[found], axis=1)
    out = {"start_distance": distance, "same_branch": np.full(count, -1), "branch": np.full(count, -1),
           "branches_in_limits": np.full(count, -1), "restart_solved": np.full(count, -1),
           "restart_branches": np.full(count, -1), "restart_others": np.full(count, -1)}
    form = closed_form_of(chain)
    if isinstance(form, str) or rotations is None:
        return out
    revolute = ~chain.is_prismatic
    tolerance = parameters["branch_tolerance"]
    nearest = form.solver.solve_many([pin.SE3(r, p) for p, r in zip(positions, rotations, strict=True)], q0)
    every = [in_limit_branches(branches, chain) for branches in form.branches(positions, rotations)]
    for i in range(count):
        out["branches_in_limits"][i] = len(every[i])
        if success[i]:
            out["branch"][i] = branch_index(q[i], every[i], revolute, tolerance)
            if nearest[i].success:
                out["same_branch"][i] = int(joint_gap(q[i], nearest[i].q, revolute) <= tolerance)
        pose = first_pose + i
        if pose < parameters["restart_targets"] and parameters["restarts"] > 0:
            target = pin.SE3(rotations[i], positions[i])
            answers = [solve(target, start) for start in
                       restart_starts(chain, seed, pose, parameters["restarts"])]
            solved = [answer.q for answer in answers if answer.success]
            out["restart_solved"][i] = len(solved)
            out["restart_branches"][i], out["restart_others"][i] = distinct_solutions(
                solved, every[i], revolute, tolerance)
    return out


def distinct_solutions(solutions: list[np.ndarray], branches: np.ndarray, revolute: np.ndarray,
                       tolerance: float) -> tuple[int, int]:
    """(distinct branches ``solutions`` equal, distinct solutions among them equal to no branch)."""
    matched: set[int] = set()
    others: list[np.ndarray] = []
    for q in solutions:
        index = branch_index(q, branches, revolute, tolerance)
        if index >= 0:
            matched.add(index)
        elif not any(joint_gap(q, other, revolute) <= tolerance for other in others):
            others.append(q)
    return len(matched), len(others)


def coverage_summary(rows: dict[str, np.ndarray]) -> dict[str, float]:
    """One method's coverage figures from its rows (NaN where a figure has no samples)."""
    solved = rows["success"].astype(bool)
    distance = rows["start_distance"][solved]
    compared = rows["same_branch"] >= 0
    sampled = rows["restart_branches"] >= 0
    available = rows["branches_in_limits"][sampled]
    reached = rows["restart_branches"][sampled]

    def share(part, whole) -> float:
        return 100.0 * part / whole if whole else math.nan

    return {
        "solved": int(solved.sum()),
        "compared": int(compared.sum()),
        "same_branch": int(np.sum(rows["same_branch"] == 1)),
        "percent_same_branch": share(int(np.sum(rows["same_branch"] == 1)), int(compared.sum())),
        "percent_on_a_branch": share(int(np.sum(rows["branch"][solved] >= 0)), int(solved.sum()))
        if np.any(rows["branches_in_limits"] >= 0) else math.nan,
        "restart_targets": int(sampled.sum()),
        "restart_solved_mean": finite_statistic(rows["restart_solved"][sampled], np.mean),
        "branches_reached_mean": finite_statistic(reached, np.mean),
        "branches_reached_max": int(np.max(reached)) if sampled.any() else -1,
        "others_mean": finite_statistic(rows["restart_others"][sampled], np.mean),
        "branches_available_mean": finite_statistic(available, np.mean),
        "percent_branches_reached": share(float(np.sum(reached)), float(np.sum(available))),
        "start_distance_median": finite_statistic(distance),
        "start_distance_p95": finite_statistic(distance, P95),
    }


def coverage_blocks(summaries: dict[str, dict], parameters: dict, form: str, restarts_run: bool,
                    histogram: Path | None) -> list[Block]:
    """The case's coverage section: what was compared, a table per method, the histogram."""
    blocks = [Block("h3", "Solution coverage and distance from the start")]
    tolerance = parameters["branch_tolerance"]
    compared = form.startswith("closed form ")  # a complete closed form (else: why there is none)
    if compared:
        blocks.append(Block("p", (
            f"Against the chain's {form}: 'same branch' is the share of answers (of those where the closed "
            f"form solves the pose from the same q0) equal to the closed form's branch nearest the start "
            f"(every joint within {tolerance:g} rad or m, revolute joints modulo 2 pi); 'on a branch' the "
            f"share of solved answers equal to one of the closed form's branches inside the limits. "
            + (f"Restarts: the case's first {parameters['restart_targets']} poses solved again from "
               f"{parameters['restarts']} random starts inside the limits (the same starts for every "
               f"method); 'branches' counts the distinct closed-form branches the solved restarts "
               f"equal, 'available' the closed form's branches inside the limits (modulo 2 pi), 'other' the "
               f"distinct solved restarts equal to no branch (near a singular pose two branches coincide and "
               f"an answer within the FK check's tolerance may differ from both by more than {tolerance:g})."
               if restarts_run else "No restarts were asked for (restarts or restart_targets is 0)."))))
    else:
        blocks.append(Block("p", f"No comparison with a closed form: {form}. Distance from the start only."))
    header = ["method", "solved"]
    if compared:
        header += ["same branch", "% same branch", "% on a branch", "restart poses", "solved restarts (mean)",
                   "branches (mean)", "branches (max)", "available (mean)", "% of available reached",
                   "other (mean)"]
    header += ["|q - q0| median", "|q - q0| p95"]
    rows = []
    for label, s in summaries.items():
        row = [label, s["solved"]]
        if compared:
            most = s["branches_reached_max"]
            row += [f"{s['same_branch']}/{s['compared']}", fmt(s["percent_same_branch"]),
                    fmt(s["percent_on_a_branch"]), s["restart_targets"], fmt(s["restart_solved_mean"]),
                    fmt(s["branches_reached_mean"]), most if most >= 0 else "-",
                    fmt(s["branches_available_mean"]), fmt(s["percent_branches_reached"]),
                    fmt(s["others_mean"])]
        rows.append([*row, fmt(s["start_distance_median"]), fmt(s["start_distance_p95"])])
    blocks.append(Block("table", header=header, rows=rows))
    blocks.append(Block("p", "|q - q0|: the Euclidean norm of a solved answer's joints minus the start (rad, "
                             "m for prismatic joints; no wrap: the motion asked of the robot)."))
    if histogram is not None:
        blocks.append(Block("image", "Joint distance from the start (solved answers)", path=histogram))
    return blocks


def distance_histogram(rows_by_method: dict[str, dict], title: str, path: Path) -> Path | None:
    """Step histograms of |q - q0| of every method's solved answers (one figure, shared bins)."""
    import matplotlib.pyplot as plt

    import wbik.study.figures as figures

    solved = {label: rows["start_distance"][rows["success"].astype(bool)]
              for label, rows in rows_by_method.items()}
    values = {label: v[np.isfinite(v)] for label, v in solved.items()}
    everything = np.concatenate(list(values.values())) if values else np.zeros(0)
    if everything.size == 0:
        return None
    figure, axes = plt.subplots(figsize=(7.0, 4.0))
    bins = np.linspace(0.0, float(everything.max()) * 1.0001 + 1e-12, 40)
    for label, v in values.items():
        if v.size:
            axes.hist(v, bins=bins, histtype="step", linewidth=1.4, label=label)
    axes.set_xlabel("|q - q0| (rad)")
    axes.set_ylabel("solved answers")
    axes.set_title(f"{title}: joint distance from the start")
    axes.legend(fontsize=8)
    return figures.save(figure, path)
