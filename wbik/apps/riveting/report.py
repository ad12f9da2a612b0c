"""Run the riveting task for each planner of a task file (tasks/ur5_riveting.yaml) and report it (dict, text,
Markdown); ``expect``: {planner name: {key of RIVETING_RULES: threshold}}."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from wbik.apps.riveting.collision import CollisionModel
from wbik.apps.riveting.cycle import NoiseModel, RunConfig, RunResult, simulate
from wbik.apps.riveting.moves import Limits
from wbik.apps.riveting.ours import QPPlanner
from wbik.apps.riveting.plan import Insertion, Planner
from wbik.apps.riveting.scene import Scene, build_scene
from wbik.apps.riveting.thesis import ThesisPlanner
from wbik.errors import InvalidConfigurationError, InvalidSettingError
from wbik.expectations import ExpectationError, Rule, evaluate, format_checks, verdict
from wbik.models import load
from wbik.scenarios.kinds import json_default, report_verdict
from wbik.solvers.method_registry import solver

PLANNERS = {"thesis": ThesisPlanner, "ours": QPPlanner}
DEFAULT_PLANNERS = [{"name": "thesis", "planner": "thesis"}, {"name": "ours"}]
THESIS_RESULT = {"rivets": 9, "collisions": 0, "localisation_error": 0.0, "score": 22}  # the thesis's Table 6


RIVETING_RULES = {
    "min_score": Rule("score", ">="),
    "max_collisions": Rule("collisions", "<="),
    "min_rivets": Rule("rivets", ">="),
    "max_failed_plans": Rule("failed_plans", "<="),
    "min_clearance_tool_m": Rule("min_clearance_tool_m", ">=", "m"),
    "min_clearance_links_m": Rule("min_clearance_links_m", ">=", "m"),
    "min_clearance_table_m": Rule("min_clearance_table_m", ">=", "m"),
    "max_lateral_error_m": Rule("max_lateral_error_m", "<=", "m"),
    "max_depth_error_m": Rule("max_depth_error_m", "<=", "m"),
    "max_all_holes_riveted_s": Rule("all_holes_riveted_s", "<=", "s"),
}


class Cell:
    """Robot, scene, collision model, limits, insertion and rivet_home's joints for one task file."""

    def __init__(self, spec: dict):
        self.robot = load(spec.get("robot", "ur5"))
        self.scene: Scene = build_scene(spec.get("scene"))
        self.collision = CollisionModel(self.robot, self.scene)
        limits = spec.get("limits", {})
        velocity = limits.get("velocity", self.robot.chain("arm").velocity_limit)
        self.limits = Limits(np.broadcast_to(np.asarray(velocity, float), (6,)).copy(),
                             float(limits.get("acceleration", 5.0)), limits.get("law", "quintic"))
        self.insertion = Insertion(**spec.get("insertion", {}))
        home = solver("analytic", self.robot, chain="arm").solve(self.scene.rivet_home, self.robot.nominal)
        if not home.success:
            raise InvalidConfigurationError(f"rivet_home is not reachable: {home.reason}")
        self.q_home = home.q

    def planner(self, entry: dict) -> Planner:
        """The planner of one ``planners`` entry, named by its ``name``."""
        options = {k: v for k, v in entry.items() if k not in ("name", "planner")}
        kind = entry.get("planner", "ours")
        if kind not in PLANNERS:
            raise InvalidSettingError(f"unknown planner {kind!r}; planners: {sorted(PLANNERS)}")
        planner = PLANNERS[kind](self.robot, self.scene, self.collision, self.limits, self.insertion,
                                 **options)
        planner.name = entry.get("name", kind)
        return planner


def run_config(spec: dict, **overrides) -> RunConfig:
    """The run's settings from a task file, with ``overrides``."""
    return RunConfig(**{"duration": float(spec.get("duration_s", 300.0)), "seed": int(spec.get("seed", 2015)),
                        "max_cycles": spec.get("max_cycles"), "noise": NoiseModel(**spec.get("noise", {})),
                        **overrides})


def run_task(spec: dict, on_progress: Callable[[dict], None] | None = None,
             keep: dict[str, RunResult] | None = None) -> dict:
    """Every planner of the task file on the same seeded hole sequence; the report dict."""
    _check_expect_keys(spec)
    cell = Cell(spec)
    config = run_config(spec)
    report = {"name": spec.get("name", ""), "kind": spec.get("kind", "ur5_riveting"),
              "robot": cell.robot.name,
              "settings": {"duration_s": config.duration, "seed": config.seed,
                           "max_cycles": config.max_cycles,
                           "acceleration_limit_rad_s2": cell.limits.acceleration,
                           "velocity_limit_rad_s": cell.limits.velocity.tolist(), "time_law": cell.limits.law,
                           "insertion": vars(cell.insertion), "noise": vars(config.noise),
                           "holes": len(cell.scene.holes), "q_home": cell.q_home.tolist()},
              "thesis_table6": THESIS_RESULT, "runs": {}, "passed": True}
    for entry in spec.get("planners", DEFAULT_PLANNERS):
        planner = cell.planner(entry)

        def progress(result: RunResult, name=planner.name) -> None:
            report["runs"][name] = {"summary": result.summary(), "setup": result.setup,
                                    "cycles": result.cycles}
            if on_progress is not None:
                on_progress(report)

        result = simulate(planner, cell.scene, cell.collision, cell.insertion, cell.q_home, config,
                          on_cycle=progress)
        if keep is not None:
            keep[planner.name] = result
        progress(result)
    judge(report, spec.get("expect", {}))
    return report


def _check_expect_keys(spec: dict) -> None:
    """Unknown planners or keys in ``expect`` raise before minutes of simulation."""
    expect = spec.get("expect") or {}
    if not isinstance(expect, dict):
        raise ExpectationError(f"ur5_riveting: 'expect' must be a mapping of planner names, got {expect!r}")
    planners = [entry.get("name", entry.get("planner", "ours"))
                for entry in spec.get("planners", DEFAULT_PLANNERS)]
    for name, wanted in expect.items():
        if name not in planners:
            raise ExpectationError(f"expect names planner {name!r}; the planners are {planners}")
        unknown = set(wanted or {}) - set(RIVETING_RULES)
        if unknown:
            raise ExpectationError(f"expect.{name}: unknown expectation key(s) {sorted(unknown)}; "
                                   f"known keys: {sorted(RIVETING_RULES)}")


def judge(report: dict, expect: dict | None) -> dict:
    """Check every planner's run against ``expect`` (``checks``, ``verdict``, ``passed``)."""
    checks = []
    for name, wanted in (expect or {}).items():
        summary = report["runs"][name]["summary"]
        figures = {**summary, "score": summary["score"]["total"],  # and every *_mm figure in m as *_m
                   **{key[:-3] + "_m": None if value is None else value / 1e3
                      for key, value in summary.items() if key.endswith("_mm")}}
        checks += [{"planner": name, **check}
                   for check in evaluate(wanted, figures, RIVETING_RULES, f"expect.{name}")]
    report["checks"] = checks
    report["verdict"] = verdict(checks)
    report["passed"] = report["verdict"] != "FAILED"
    return report


def _fmt(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def comparison_rows(report: dict) -> list[list[str]]:
    rows = [["planner", "score", "loc/riv/coll", "rivets", "collisions", "loc. error mm / deg",
             "min tool clearance mm", "min link clearance mm", "mean cycle s", "failed plans",
             "all holes riveted at s", "planning charged s (wall s)"]]
    for name, run in report["runs"].items():
        s = run["summary"]
        sc = s["score"]
        rows.append([name, f"{sc['total']}/30", f"{sc['localisation']}/{sc['rivets']}/{sc['collisions']}",
                     str(s["rivets"]), str(s["collisions"]),
                     f"{_fmt(s['mean_localisation_error_mm'], 4)} / {_fmt(s['mean_axis_error_deg'], 4)}",
                     _fmt(s["min_clearance_tool_mm"], 3), _fmt(s["min_clearance_links_mm"], 1),
                     _fmt(s["mean_cycle_time_s"], 2), str(s["failed_plans"]),
                     _fmt(s.get("all_holes_riveted_s"), 1),
                     f"{_fmt(s.get('planning_charged_s'), 2)} ({_fmt(s.get('planning_time_s'), 1)})"])
    thesis = ["thesis (Table 6)", "22/30", "10/2/10", "9", "0", "0", "-", "-", "~33 (300/9)", "-", "-", "-"]
    return [*rows, thesis]


def format_text(report: dict) -> str:
    rows = comparison_rows(report)
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = [f"{report['name']} (ur5_riveting): {report_verdict(report)}"]
    settings = report["settings"]
    lines.append(f"  {settings['duration_s']:g} s, seed {settings['seed']}, {settings['holes']} holes, "
                 f"a_max {settings['acceleration_limit_rad_s2']:g} rad/s^2, v_max URDF, "
                 f"{settings['time_law']} law")
    for row in rows:
        lines.append("  " + "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)))
    for name, run in report["runs"].items():
        s = run["summary"]
        lines.append(f"  {name}: simulated {s['simulated_time_s']:.1f} s, table clearance "
                     f"{_fmt(s['min_clearance_table_mm'], 1)} mm, max lateral error "
                     f"{_fmt(s['max_lateral_error_mm'], 6)} mm, planning charged "
                     f"{s.get('planning_charged_s', 0.0):.2f} s (cost model; measured wall "
                     f"{s['planning_time_s']:.1f} s, not charged), run wall {s['wall_time_s']:.1f} s")
        visited = s.get("states_visited") or {}
        lines.append("    states visited: " + ", ".join(f"{k} {v}" for k, v in visited.items()))
    for planner in dict.fromkeys(check["planner"] for check in report.get("checks", [])):
        lines.append(f"  expectations of {planner}:")
        lines.extend(format_checks([c for c in report["checks"] if c["planner"] == planner], indent="    "))
    return "\n".join(lines)


def format_markdown(report: dict) -> str:
    rows = comparison_rows(report)
    table = ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join([f"# {report['name']}", "", table[0], "|" + "---|" * len(rows[0]), *table[1:]]) + "\n"


def write_report(report: dict, folder: str | Path) -> list[Path]:
    """report.json and report.md in ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / "report.json", folder / "report.md"]
    paths[0].write_text(json.dumps(report, indent=1, default=json_default))
    paths[1].write_text(format_markdown(report))
    return paths
