"""Run a study file (default: comparisons/default.yaml): raw rows, summary, Mann-Whitney tests, figures and
a Markdown + HTML report in the output folder, where an interrupted run resumes when run again.

With ``--compare-to OLD`` (an earlier run's output folder) the report compares the runs target by target,
per case and method: a regression gate for CI (the study file's ``regression:`` rule; exit codes below)."""

from __future__ import annotations

import argparse
from pathlib import Path

from wbik.errors import UsageError

HELP = "run a comparison study of IK methods and write its report"
EPILOG = ("Exit codes: 0 done (no regression), 1 a method regressed against --compare-to OLD, 2 bad input "
          "or usage, 3 internal error, 4 OLD's targets or settings differ from this run's (not compared).")
EXIT_OTHER_TARGETS = 4  # --compare-to OLD holds a run on other targets or settings: nothing compared


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", nargs="?",
                        help="study file (.yaml or .toml), or the name of a shipped study "
                             "(e.g. robots); default comparisons/default.yaml")
    parser.add_argument("--output", "-o", type=Path, help="output folder (default runs/<study name>/)")
    parser.add_argument("--jobs", "-j", type=int, default=2, help="parallel workers (default 2)")
    parser.add_argument("--backend", default="loky", choices=("loky", "sequential", "dask"),
                        help="joblib backend: loky (local processes, default), sequential, or dask")
    parser.add_argument("--scheduler",
                        help="Dask scheduler address (tcp://host:8786); with --backend dask and "
                             "no address, a local Dask cluster of --jobs workers is started")
    parser.add_argument("--poses", type=int, help="override the number of poses of every case")
    parser.add_argument("--methods", help="comma-separated method labels to run (default: all of the study)")
    parser.add_argument("--robot", help="run the (single-case) study on another robot, e.g. ur5")
    parser.add_argument("--chain", help="chain of --robot (default: its only chain)")
    parser.add_argument("--seed", type=int, help="override the study's seed")
    parser.add_argument("--chunk-size", type=int,
                        help="poses per chunk (unit of parallel work and of resume)")
    parser.add_argument("--name", help="rename the study (changes the default output folder)")
    parser.add_argument("--fresh", action="store_true", help="delete earlier results in the output folder")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--report-only", action="store_true",
                        help="rebuild the report from the results already in the output folder")
    parser.add_argument("--budget-curves", type=int, metavar="POSES",
                        help="success-versus-budget curves on this many poses per case (0: none; "
                             "default: the study file's budget_curves:)")
    parser.add_argument("--no-figures", action="store_true",
                        help="write the report's tables without its figures (quicker; the rows are the same)")
    parser.add_argument("--compare-to", type=Path, metavar="OLD",
                        help="compare with the output folder of an earlier run of the study on the same "
                             "targets; exit 1 when a method regressed (the study file's regression: rule), "
                             "4 when the targets differ")


def check_output_folder(output: Path | None) -> None:
    """UsageError if ``--output`` names something that cannot be the output folder."""
    if output is not None and output.exists() and not output.is_dir():
        raise UsageError(f"--output {str(output)!r} is an existing file; the study writes a folder of "
                         "results there: pass a folder path (new or from an earlier run)")


def run(args: argparse.Namespace) -> int:
    from wbik.study import load_study, run_study
    from wbik.study.compare import compare_runs, refusal_before_the_run, summary_lines
    from wbik.study.definition import with_overrides
    from wbik.study.ownership import FolderLock
    from wbik.study.report import write_report
    from wbik.study.runner import default_output

    check_output_folder(args.output)
    if args.jobs < 1:
        raise UsageError(f"--jobs must be at least 1, got {args.jobs}")
    if args.report_only and args.fresh:
        raise UsageError("--report-only reads the results in the output folder; --fresh would delete "
                         "them: give one or the other")

    compare_to = args.compare_to
    if compare_to is not None and not (compare_to / "study.json").is_file():
        raise UsageError(f"--compare-to {str(compare_to)!r} holds no results of a study (no study.json): "
                         "pass the output folder of an earlier 'wbik study' run")
    study = with_overrides(load_study(args.file),
        poses=args.poses, methods=[m.strip() for m in args.methods.split(",")] if args.methods else None,
        robot=args.robot, chain=args.chain, chunk_size=args.chunk_size, seed=args.seed, name=args.name,
        budget_curve_poses=args.budget_curves, figures=False if args.no_figures else None)
    # other settings or cases: nothing to compare, so nothing to run
    if compare_to is not None and (differs := refusal_before_the_run(study, compare_to)):
        print("\n".join([f"not compared with {compare_to}: the runs' targets differ (nothing run):",
                         *(f"  {line}" for line in differs)]))
        return EXIT_OTHER_TARGETS
    if args.report_only:
        output = args.output or default_output(study)
        check_output_folder(output)
        if not (output / "study.json").is_file():
            raise UsageError(f"--report-only: {str(output)!r} holds no results of a study (no study.json); "
                             f"run 'wbik study' first, or pass --output FOLDER of an earlier run")
    else:
        output = run_study(study, args.output, jobs=args.jobs, backend=args.backend,
                           scheduler=args.scheduler, fresh=args.fresh, progress=not args.no_progress,
                           report=compare_to is None)
    comparison = None
    if args.report_only or compare_to is not None:
        with FolderLock(output):  # not while a run is writing into it
            if compare_to is not None:
                comparison = compare_runs(study, output, compare_to)
            markdown, html = write_report(study, output, comparison)
    else:
        markdown, html = output / "report.md", output / "report.html"
    print(f"report: {markdown}\n        {html}")
    if comparison is None:
        return 0
    print("\n".join(summary_lines(comparison)))
    return EXIT_OTHER_TARGETS if comparison.refused else int(bool(comparison.regressions))
