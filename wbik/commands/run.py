"""Run a scenario file (YAML, JSON or TOML; its 'kind' selects the runner) or a shipped task by its name
(wbik run bioloid_balance; 'wbik tasks' lists them). --output writes the JSON report after every phase."""

from __future__ import annotations

import argparse

from wbik.commands.arguments import print_json
from wbik.errors import UsageError

HELP = "run a scenario file (e.g. tasks/bioloid_balance.yaml, or a shipped task's name)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("taskfile", help="scenario file (YAML or JSON), or the name of a shipped task")
    parser.add_argument("--output", "-o", help="write the JSON report here (updated after every phase)")
    parser.add_argument("--backend", help="override the QP backend (osqp, daqp, quadprog, proxqp, fastest, "
                                           "default)")
    parser.add_argument("--json", action="store_true", help="print the JSON report instead of the summary")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from wbik.data import task_path
    from wbik.scenarios import format_report, load_scenario, run_scenario_report
    from wbik.scenarios.kinds import KIND_REGISTRY

    if args.output is not None and Path(args.output).is_dir():
        raise UsageError(f"--output {args.output!r} is a folder; it names the JSON report file, "
                         "e.g. --output runs/report.json")
    taskfile = str(task_path(args.taskfile))  # a path as given, else a shipped task of that name
    spec = load_scenario(taskfile)  # checked against its kind's schema: errors name the file and key
    if args.backend:
        if not KIND_REGISTRY.get(spec["kind"]).takes("backend"):
            takes = sorted(name for name, kind in KIND_REGISTRY.entries().items() if kind.takes("backend"))
            raise UsageError(f"--backend: a {spec['kind']} scenario solves no QP with a file-wide backend; "
                             f"--backend applies to the kinds {', '.join(takes)}")
        spec["backend"] = args.backend
    report = run_scenario_report(spec, output=args.output, source=taskfile)  # checks the backend too
    if args.json:
        print_json(report.as_dict())
    else:
        print(format_report(report))
    return 0 if report.passed else 1  # 1: ran, but did not pass
