"""The case kind ``path`` (a case with a ``path:`` mapping): lines and circles in the task space of one
chain, followed point by point by every method (docs/guide/studies.md, "Path studies")."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

import wbik.study.results as store
from wbik.robot import Chain
from wbik.schema import Boolean, Context, Key, Map, Number, Text, join
from wbik.solvers.method_registry import budget_options
from wbik.study.blocks import Block, fmt, fmt_interval, reason_blocks, status_blocks, write_case_tables
from wbik.study.chain_targets import ChainChunkTask, ChainTargets
from wbik.study.context import _frozen, chain_of, make_solver
from wbik.study.path_metrics import (
    branch_labels,
    circle_points,
    line_points,
    path_metrics,
    random_plane,
    random_unit,
    slerped_rotations,
)
from wbik.study.sampling import PoseSet, saved_extras
from wbik.study.spec import CaseSpec, Study
from wbik.study.statistics import P95, finite_statistic, wilson_interval
from wbik.study.target_parameters import Parameter, integer, number
from wbik.study.target_sets import target_stream

PATH = "path"
SHAPES = ("line", "circle")
ORIENTATIONS = ("hold", "slerp")


PATH_PARAMETERS = {
    "shape": Parameter("line", "'line' or 'circle'", Text(SHAPES), "the path's shape"),
    "length": Parameter(0.2, "a length in m, in (0, 10]", number(0.0, 10.0, low_open=True),
                        "a line's length (m)"),
    "radius": Parameter(0.1, "a radius in m, in (0, 5]", number(0.0, 5.0, low_open=True),
                        "a circle's radius (m)"),
    "points": Parameter(50, "an integer in [2, 10000] (points per path, the start included)",
                        integer(2, 10_000), "points per path, the start included"),
    "orientation": Parameter("hold", "'hold' or 'slerp'", Text(ORIENTATIONS),
                             "the orientation held, or slerped by angle about a random axis"),
    "angle": Parameter(0.5, "an angle in rad, in (0, pi]", number(0.0, math.pi, low_open=True),
                       "the rotation from the first to the last point (rad)"),
    "jump": Parameter(0.5, "a joint step in rad (m for a prismatic joint), in (0, 2 pi]",
                      number(0.0, 2.0 * math.pi, low_open=True),
                      "a step between consecutive points larger than this on some joint is a jump"),
    "reachable": Parameter(True, "true or false", Boolean(),
                           "keep only paths whose every point has a witness configuration"),
    "attempts": Parameter(50, "an integer in [1, 1000] (draws per path)", integer(1, 1000),
                          "draws per path until one has a witness at every point"),
    "branch_tolerance": Parameter(1e-3, "a number in (0, 0.5] (rad or m)", number(0.0, 0.5, low_open=True),
                                  "largest joint difference of an answer and the closed-form branch it is"),
}
# parameters of one shape or orientation only: key -> (the deciding key, its value)
ONLY_FOR = {"length": ("shape", "line"), "radius": ("shape", "circle"), "angle": ("orientation", "slerp")}
WITNESS_METHOD = "bounded_lm"
WITNESS_BUDGET_S = 0.02  # per solve: an iteration budget, the same on any machine
WITNESS_RESTARTS = 10  # random starts at a point the previous point's witness does not reach


def path_schema() -> Map:
    """A case's ``path:`` with its defaults, and ``count`` (the number of paths) if given."""

    def only_for(checked: dict, path: str, ctx: Context) -> None:
        for key, (decider, value) in ONLY_FOR.items():
            if checked[decider] != value:
                if key in checked:
                    ctx.says(join(path, key), f"applies to {decider}: {value} only (this path's {decider} "
                                              f"is {checked[decider]})")
            elif key not in checked:
                checked[key] = PATH_PARAMETERS[key].default

    keys = {key: (Key(parameter.node, doc=parameter.description) if key in ONLY_FOR else parameter.key)
            for key, parameter in PATH_PARAMETERS.items()}
    keys["count"] = Key(Number(integer=True, gt=0, what="a positive integer (paths)"),
                        doc="how many paths (the case's poses)")
    return Map(keys, post=only_for, nullable=True,
               what="a mapping {shape: line|circle, length or radius, points, count, ...}")


def describe(parameters: dict) -> str:
    """The paths in words: "line of 0.2 m, 50 points, orientation held"."""
    shape = (f"line of {parameters['length']:g} m" if parameters["shape"] == "line"
             else f"circle of radius {parameters['radius']:g} m")
    turn = ("orientation held" if parameters["orientation"] == "hold"
            else f"orientation slerped by {parameters['angle']:g} rad")
    return f"{shape}, {parameters['points']} points, {turn}"


def draw_path(chain: Chain, rng: np.random.Generator, parameters: dict
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q_start (n,), positions (N, 3), rotations (N, 3, 3)) of one path drawn from ``rng``."""
    q_start = chain.random(rng)
    tip = chain.fk(q_start)
    count = parameters["points"]
    if parameters["shape"] == "line":
        positions = line_points(tip.translation, random_unit(rng), parameters["length"], count)
    else:
        u, v = random_plane(rng)
        positions = circle_points(tip.translation, u, v, parameters["radius"], count)
    axis = random_unit(rng) if parameters["orientation"] == "slerp" else None
    return q_start, positions, slerped_rotations(tip.rotation, axis, parameters.get("angle", 0.0), count)


def witness_path(solver, chain: Chain, rng: np.random.Generator, q_start: np.ndarray, positions: np.ndarray,
                 rotations: np.ndarray) -> np.ndarray | None:
    """(N, n) configurations passing the shared check at every point, each solved from the previous one
    (else from random starts); None at a point none reaches."""
    from wbik.targets import Target

    q, found = q_start, []
    for position, rotation in zip(positions, rotations, strict=True):
        target = Target(position, rotation)
        answer = solver.solve(target, q)
        restarts = 0
        while not answer.success and restarts < WITNESS_RESTARTS:
            answer = solver.solve(target, chain.random(rng))
            restarts += 1
        if not answer.success:
            return None
        q = answer.q
        found.append(q)
    return np.array(found)


@dataclass
class PathSet(PoseSet):
    """Paths: starts ``q_true`` = ``q0`` (count, n), ``positions`` (count, N, 3), ``rotations``
    (count, N, 3, 3), and per path its draws, whether a witness was found, the witness's length."""

    draws: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    verified: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    witness_length: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def saved_arrays(self) -> dict[str, np.ndarray]:
        return {"q_true": self.q_true, "positions": self.positions, "rotations": self.rotations,
                "q0": self.q0, "path_draws": self.draws, "path_verified": self.verified,
                "path_witness_length": self.witness_length}


def sample_paths(chain: Chain, count: int, seed: int, parameters: dict, witness=None) -> PathSet:
    """``count`` paths; ``witness``: the solver of the witnesses (None: no check)."""
    n, points = chain.nq, parameters["points"]
    q_start = np.empty((count, n))
    positions, rotations = np.empty((count, points, 3)), np.empty((count, points, 3, 3))
    draws = np.zeros(count, dtype=int)
    verified = np.zeros(count, dtype=bool)
    witness_length = np.full(count, np.nan)
    for index in range(count):
        rng = target_stream(seed, PATH, index)
        for draw in range(1, parameters["attempts"] + 1):
            drawn = draw_path(chain, rng, parameters)
            draws[index] = draw
            if witness is None or not parameters["reachable"]:
                break
            if (joints := witness_path(witness, chain, rng, *drawn)) is not None:
                verified[index] = True
                witness_length[index] = float(np.abs(np.diff(joints, axis=0)).sum())
                break
        q_start[index], positions[index], rotations[index] = drawn
    return PathSet(q_start, positions, rotations, q_start.copy(), draws, verified, witness_length)


@dataclass(frozen=True)
class PathChunkTask(ChainChunkTask):
    """A chunk of paths (``positions`` (k, N, 3), ``rotations`` (k, N, 3, 3)) and the flip criteria."""

    jump: float = 0.5
    branch_tolerance: float = 1e-3


class PathTargets(ChainTargets):
    """Paths in the task space of one chain, followed point by point."""

    entry_keys = ("path",)

    def __init__(self, name: str = PATH):
        super().__init__(name, target="pose")

    def entry_schema(self) -> dict[str, Key]:
        return {"path": Key(path_schema(), {}, doc="the path's shape and parameters")}

    def entry(self, item: dict, path: str, ctx: Context) -> dict:
        from wbik.study.definition import _case_name

        if item.get("reference"):
            ctx.says(join(path, "reference"), "does not apply to a path case")
        parameters = dict(item["path"])
        count = parameters.pop("count", None)
        completed = {**item, "path": parameters, "target": self.name}
        if count is not None:
            if item.get("poses") not in (None, count):
                ctx.fail(path, f"path.count ({count}) and poses ({item['poses']}) both say how many paths; "
                               "give one")
            completed["poses"] = count
        robot = item.get("robot")
        if "name" not in item and isinstance(robot, str) and robot:
            chain = item.get("chain") or (f"{item['base']}_to_{item['tip']}" if item.get("base") and
                                          item.get("tip") else None)
            completed["name"] = _case_name(robot, chain, f"{parameters['shape']}_path")
        return completed

    def parameters_of(self, case: CaseSpec) -> dict:
        if case.path:
            return dict(case.path)
        defaults = path_schema().check(None, "path", Context("defaults"))
        defaults.pop("count", None)
        return defaults

    def sampling_text(self, case: CaseSpec) -> str:
        return describe(self.parameters_of(case))

    def sample(self, study: Study, case: CaseSpec) -> PathSet:
        chain = chain_of(case)
        parameters = self.parameters_of(case)
        witness = None
        if parameters["reachable"]:
            timeout_s, options = budget_options(WITNESS_METHOD, WITNESS_BUDGET_S, {})
            witness = make_solver(case.robot, _frozen(case.robot_params), case.chain, WITNESS_METHOD, options,
                                  timeout_s, (study.tolerances["position"], study.tolerances["rotation"]),
                                  study.seed, case.base, case.tip)
        return sample_paths(chain, study.poses_of(case), study.seed, parameters, witness)

    task_type = PathChunkTask

    def task_fields(self, study: Study, case: CaseSpec) -> dict:
        parameters = self.parameters_of(case)
        return {"jump": parameters["jump"], "branch_tolerance": parameters["branch_tolerance"]}

    def throughput(self, task: PathChunkTask, workers: int) -> None:
        """None: a path is followed point by point from the last answer, which no batch can do."""
        return None

    def solve(self, task: PathChunkTask) -> dict[str, np.ndarray]:
        """Every path of the chunk followed: the per-point columns (``point_*``) and the path metrics."""
        from wbik.study.solution_coverage import closed_form_of
        from wbik.targets import Target

        solver = self.build(task)
        chain = solver.chain
        count, points, n = task.count, task.positions.shape[1], chain.nq
        watch = task.timeout_s is not None and solver.timeout_s is not None and solver.budgeted
        form = closed_form_of(chain)
        form = None if isinstance(form, str) else form
        empty = {"success": False, "reason": "", "time_s": np.nan, "iterations": 0, "position_error": np.nan,
                 "rotation_error": np.nan, "branch": -1}
        columns = {f"point_{key}": np.full((count, points), value, dtype=object if key == "reason" else None)
                   for key, value in empty.items()}
        columns["point_q"] = np.full((count, points, n), np.nan)
        cpu = np.zeros(count)
        reruns = np.zeros(count, dtype=int)
        for path in range(count):
            q_previous = task.q0[path]
            for point in range(points):
                target = Target(task.positions[path, point], task.rotations[path, point])
                answer, seconds, again = self.solve_one(task, solver, target, q_previous)
                cpu[path] += 0.0 if math.isnan(seconds) else seconds
                reruns[path] += again
                for key in store.ROW_FIELDS[1:]:
                    columns[f"point_{key}"][path, point] = getattr(answer, key)
                if answer.q is not None:
                    columns["point_q"][path, point] = answer.q
                if answer.success:
                    q_previous = answer.q
            if form is not None:
                columns["point_branch"][path] = branch_labels(
                    form, task.positions[path], task.rotations[path], columns["point_q"][path],
                    columns["point_success"][path], task.branch_tolerance)
        columns["point_reason"] = columns["point_reason"].astype(str)
        return {**path_columns(columns, task.first_pose, task.jump, form is not None),
                "cpu_s": np.where(watch, cpu, np.nan), "reruns": reruns, **columns}

    def analyse(self, study: Study, case: CaseSpec, output: Path) -> dict:
        from wbik.study.solution_coverage import closed_form_of

        directory, rows_by_method, not_applicable, chain = self.case_results(study, case, output)
        write_point_csv(directory / "raw.csv", rows_by_method, chain.joint_names)
        store.write_csv(directory / "paths.csv", ["path", "method", "whole", *PATH_CSV_KEYS, "reason"],
                        (row for label, rows in rows_by_method.items()
                         for row in store.method_csv_rows(label, rows, ["success", *PATH_CSV_KEYS, "reason"],
                                                          joints=False)))
        common = common_paths(rows_by_method)
        summaries = {label: path_summary(rows, common) for label, rows in rows_by_method.items()}
        write_case_tables(directory, summaries, [])
        form = closed_form_of(chain)
        images = {}
        if rows_by_method and study.figures:
            title = f"{case.robot}.{chain.name} ({self.sampling_text(case)})"
            images["paths"] = path_figure(rows_by_method, title, directory / "figures" / "paths.png")
        return {"case": case, "chain": chain, "rows": rows_by_method, "not_applicable": not_applicable,
                "summaries": summaries, "tests": [], "baseline": None, "images": images,
                "drawing": saved_extras(directory / "poses.npz", "path_"), "common": int(common.sum()),
                "closed_form": (f"not counted, {form}" if isinstance(form, str)
                                else f"counted on the closed form {form.family}"),
                "parameters": self.parameters_of(case)}

    def blocks(self, study: Study, analysis: dict) -> list[Block]:
        case: CaseSpec = analysis["case"]
        chain, parameters, drawing = analysis["chain"], analysis["parameters"], analysis["drawing"]
        words = (f"{study.poses_of(case)} paths (seed {study.seed}), each a {describe(parameters)}: from the "
                 "tip pose of a start configuration uniform inside the limits, ")
        words += ("in a direction uniform on the sphere" if parameters["shape"] == "line"
                  else "in a plane through the tip uniform among planes (the last point is the first)")
        if parameters["orientation"] == "slerp":
            words += ", the orientation turning about an axis uniform on the sphere"
        words += (f". Chain {chain.base_frame} -> {chain.tip_frame}, {chain.nq} joints "
                  f"({', '.join(chain.joint_names)}). Every method solves the first point from the start "
                  "configuration, then each point from its answer at the last solved point (the study's "
                  "start setting does not apply).")
        blocks = [Block("h2", f"Case {case.name}: {case.robot}.{chain.name}, {parameters['shape']} paths"),
                  Block("p", words)]
        if parameters["reachable"] and drawing:
            draws = drawing.get("draws", np.zeros(0))
            unverified = int(np.sum(~drawing.get("verified", np.ones(0, dtype=bool))))
            text = (f"Every point of a path was checked reachable before the path was kept: a witness "
                    f"configuration inside the limits passing the shared check ({WITNESS_METHOD} from the "
                    f"previous point's witness, else from up to {WITNESS_RESTARTS} random starts). "
                    f"{int(np.sum(draws - 1))} drawn paths were rejected on the way")
            text += (f" (at most {int(draws.max())} draws for one path)" if draws.size else "") + "."
            if unverified:
                text += (f" {unverified} path(s) found no witness in {parameters['attempts']} draws and were "
                         "kept unverified.")
            blocks.append(Block("p", text))
        blocks.extend(status_blocks(study, analysis))
        summaries = analysis["summaries"]
        if not summaries:
            return blocks
        blocks.append(Block("h3", "Paths followed"))
        blocks.append(Block("table", header=[
            "method", "whole paths", "% whole (95 % CI)", "% points solved", "paths with a flip", "flips",
            "jumps", "branch changes", "largest step (max)", "largest step (median)",
            "path length (median, whole paths)", f"path length (median, {analysis['common']} common paths)",
            "ms per point (median)", "ms per path (median)", "re-run (CPU starved)"],
            rows=[[label, f"{s['solved']}/{s['poses']}",
                   f"{fmt(s['percent_solved'])} "
                   f"{fmt_interval(s['percent_solved_ci_low'], s['percent_solved_ci_high'])}",
                   fmt(s["percent_points_solved"]), str(s["paths_with_flips"]), str(s["flips"]),
                   str(s["jumps"]),
                   str(s["branch_changes"]) if s["branches_known"] else "-", fmt(s["largest_step_max"]),
                   fmt(s["largest_step_median"]), fmt(s["length_median"]), fmt(s["length_common_median"]),
                   fmt(s["time_point_median_ms"]), fmt(s["time_all_median_ms"]), str(s["rerun"])]
                  for label, s in summaries.items()]))
        blocks.append(Block("p", (
            "A whole path: every point solved. The robot moves between consecutive solved points (an "
            "unsolved point is skipped); a step's size is its largest |dq| over the joints (rad, m for a "
            f"prismatic joint); a jump is a step above {parameters['jump']:g}; a branch change a step "
            "between answers on different branches of the chain's complete closed form (the index of the "
            f"branch each answer equals within {parameters['branch_tolerance']:g}); a flip either. Branch "
            f"changes: {analysis['closed_form']}. Path length: sum over the steps of sum_j |dq_j| (rad), "
            "median over the paths the method solved whole, and over the paths every method solved whole. "
            "Times are per call of the method alone; a path's time is the sum over its points.")))
        blocks.extend(reason_blocks(analysis["rows"], "Most frequent reasons for a path not solved whole "
                                    "(its first unsolved point's):", "paths"))
        if "paths" in analysis["images"]:
            blocks.append(Block("image", "Paths solved at each point, and joint path length per method",
                                path=analysis["images"]["paths"]))
        return blocks


def path_columns(points: dict[str, np.ndarray], first_path: int, jump: float, branches_known: bool
                 ) -> dict[str, np.ndarray]:
    """A chunk's per-path columns from its per-point ones: ``success`` (whole path), ``reason`` (the first
    unsolved point's), sums, the :class:`~wbik.study.path_metrics.PathMetrics`, ``q`` (the last answer)."""
    success = points["point_success"]
    count, _ = success.shape
    metrics = [asdict(path_metrics(points["point_q"][i], success[i], jump,
                                   points["point_branch"][i] if branches_known else None))
               for i in range(count)]
    whole = [m.pop("whole") for m in metrics]
    reasons = []
    last_q = np.full((count, points["point_q"].shape[2]), np.nan)
    for i in range(count):
        missed, solved = np.flatnonzero(~success[i]), np.flatnonzero(success[i])
        reasons.append(f"point {missed[0]}: {points['point_reason'][i, missed[0]]}" if missed.size else "")
        if solved.size:
            last_q[i] = points["point_q"][i, solved[-1]]
    return {"pose": np.arange(first_path, first_path + count), "success": np.array(whole, dtype=bool),
            "reason": np.array(reasons, dtype=str), "time_s": np.nansum(points["point_time_s"], axis=1),
            "iterations": points["point_iterations"].sum(axis=1),
            **{key: np.array([m[key] for m in metrics]) for key in metrics[0]},
            "branches_known": np.full(count, branches_known), "q": last_q}


def common_paths(rows_by_method: dict[str, dict]) -> np.ndarray:
    """The paths every method solved whole (a mask over the paths)."""
    masks = [rows["success"].astype(bool) for rows in rows_by_method.values()]
    return np.logical_and.reduce(masks) if masks else np.zeros(0, dtype=bool)


def path_summary(rows: dict[str, np.ndarray], common: np.ndarray) -> dict:
    """One method's figures over a case's paths (summary.csv); ``common``: the paths all solved whole."""
    whole = rows["success"].astype(bool)
    count, solved = int(whole.size), int(whole.sum())
    low, high = wilson_interval(solved, count)
    point_success = rows["point_success"].astype(bool)
    point_ms = rows["point_time_s"] * 1e3
    return {
        "poses": count, "solved": solved, "percent_solved": 100.0 * solved / count if count else math.nan,
        "percent_solved_ci_low": 100.0 * low, "percent_solved_ci_high": 100.0 * high,
        "points": int(point_success.size),
        "percent_points_solved": 100.0 * float(point_success.mean()) if point_success.size else math.nan,
        "paths_with_flips": int(np.sum(rows["flips"] > 0)), "flips": int(rows["flips"].sum()),
        "jumps": int(rows["jumps"].sum()), "branch_changes": int(rows["branch_changes"].sum()),
        "branches_known": bool(rows["branches_known"].all()) if count else False,
        "largest_step_max": finite_statistic(rows["largest_step"], np.max),
        "largest_step_median": finite_statistic(rows["largest_step"]),
        "length_median": finite_statistic(rows["length"][whole]),
        "length_common_median": finite_statistic(rows["length"][common] if common.size == count else []),
        "time_point_median_ms": finite_statistic(point_ms),
        "time_point_p95_ms": finite_statistic(point_ms, P95),
        "time_all_median_ms": finite_statistic(rows["time_s"] * 1e3),
        "raised": int(sum(str(reason).startswith("raised") for reason in rows["point_reason"].ravel())),
        "rerun": int(np.sum(rows["reruns"] > 0)) if "reruns" in rows else 0,
    }


PATH_CSV_KEYS = ("points_solved", "jumps", "branch_changes", "flips", "largest_step", "length", "time_s",
                 "iterations")


def write_point_csv(path: Path, rows_by_method: dict[str, dict], joint_names: list[str]) -> None:
    """raw.csv: a row per (path, point, method), with the step from the last solved point and the branch."""
    keys = store.ROW_FIELDS[1:]

    def rows():
        for label, rows in rows_by_method.items():
            for i, path_index in enumerate(rows["pose"]):
                solved = rows["point_success"][i].astype(bool)
                q = rows["point_q"][i]
                indices = np.flatnonzero(solved)
                steps = np.full(solved.size, np.nan)
                steps[indices[1:]] = np.max(np.abs(np.diff(q[indices], axis=0)), axis=1)
                columns = [np.full(solved.size, path_index), np.arange(solved.size), [label] * solved.size,
                           *(rows[f"point_{key}"][i] for key in keys), steps, rows["point_branch"][i], *q.T]
                yield from zip(*(store.csv_cells(column) for column in columns), strict=True)

    store.write_csv(path, ["path", "point", "method", *keys, "step", "branch",
                           *(f"q_{name}" for name in joint_names)], rows())


def path_figure(rows_by_method: dict[str, dict], title: str, path: Path) -> Path:
    """% of the paths solved at point k against k; a box per method of the whole paths' joint lengths."""
    import matplotlib.pyplot as plt

    import wbik.study.figures as figures

    labels = list(rows_by_method)
    colour = figures.colours(labels)
    figure, (along, lengths) = plt.subplots(1, 2, figsize=(max(10.0, 1.0 * len(labels) + 7), 4.2),
                                            gridspec_kw={"wspace": 0.3})
    for label in labels:
        success = rows_by_method[label]["point_success"].astype(bool)
        along.plot(np.arange(success.shape[1]), 100.0 * success.mean(axis=0), color=colour[label],
                   label=label, linewidth=1.3)
    along.set_xlabel("point along the path")
    along.set_ylabel("% of paths solved at the point")
    along.set_ylim(-2, 102)
    along.legend(fontsize=7)
    whole = [rows["length"][rows["success"].astype(bool)] for rows in rows_by_method.values()]
    figures.boxes(lengths, [figures.positive(length) for length in whole], list(colour.values()), alpha=0.6)
    lengths.set_yscale("log")
    lengths.set_xticks(np.arange(1, len(labels) + 1), labels, rotation=30, ha="right")
    lengths.set_ylabel("joint path length, sum |dq| (rad), whole paths")
    figure.suptitle(title, fontsize=10)
    return figures.save(figure, path)


CASE_KINDS = (PathTargets(),)
