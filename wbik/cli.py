"""The ``wbik`` command: each subcommand is a module of :data:`SUBCOMMANDS` with ``HELP``, a docstring,
``run(args) -> int``, optionally ``EPILOG`` and ``add_arguments(parser)``."""

from __future__ import annotations

import argparse
import inspect
import os
import sys
import traceback
from types import ModuleType

import wbik.commands.fk as fk
import wbik.commands.methods as methods
import wbik.commands.robots as robots
import wbik.commands.run as run
import wbik.commands.solve as solve
import wbik.commands.study as study
import wbik.commands.tasks as tasks
import wbik.commands.view as view
from wbik.errors import WbikError

SUBCOMMANDS = (robots, methods, fk, solve, study, view, run, tasks)  # in ``wbik --help``'s order
EXIT_USAGE, EXIT_INTERNAL = 2, 3
EXIT_BROKEN_PIPE = 141  # standard output's reader went away (128 + SIGPIPE)


def checked_subcommand(module: ModuleType) -> ModuleType:
    """``module`` if it has ``HELP``, a docstring and ``run``, else an error (exit code 3)."""
    if missing := [what for what, ok in (("HELP", isinstance(getattr(module, "HELP", None), str)),
                                         ("docstring", bool(module.__doc__)),
                                         ("run(args)", callable(getattr(module, "run", None)))) if not ok]:
        raise ImportError(f"{module.__name__} has no {', '.join(missing)}; every subcommand module needs "
                          "them (see wbik.cli)", name=module.__name__)
    return module


def build_parser() -> argparse.ArgumentParser:
    """The parser with every subcommand; a subcommand module that fails to import is an error."""
    parser = argparse.ArgumentParser(
        prog="wbik",
        description="Whole-body inverse kinematics: every IK method behind one interface, on Pinocchio.",
        epilog="Units: metres and radians unless an option names degrees. "
               "Run 'wbik COMMAND --help' for each command. Exit codes: 0 done/solved, 1 not solved, "
               "2 bad input or usage, 3 internal error.")
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of errors (for bug reports)")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in SUBCOMMANDS:
        module = checked_subcommand(module)
        command = subparsers.add_parser(module.__name__.rpartition(".")[2], help=module.HELP,
                                        description=inspect.cleandoc(module.__doc__),
                                        epilog=getattr(module, "EPILOG", None))
        if hasattr(module, "add_arguments"):
            module.add_arguments(command)
        # --debug is also accepted after the subcommand; SUPPRESS keeps the global value otherwise
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                             help="print the traceback of errors (for bug reports)")
        command.set_defaults(run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    debug = "--debug" in argv
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # argparse: 0 for --help, 2 for a usage error (message printed)
            return exc.code if isinstance(exc.code, int) else EXIT_USAGE
        debug = bool(getattr(args, "debug", False))
        if not getattr(args, "command", None):
            parser.print_help(sys.stderr)
            return EXIT_USAGE
        return int(args.run(args) or 0)
    except WbikError as exc:
        if debug:
            traceback.print_exc()
        print(f"wbik: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("wbik: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader left (``wbik ... | head``): stop quietly, as a killed pipe does
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's final flush would fail again
        return EXIT_BROKEN_PIPE
    except Exception as exc:  # noqa: BLE001 - the one place that turns a bug into exit code 3
        if debug:
            traceback.print_exc()
        print(f"wbik: internal error: {type(exc).__name__}: {exc}\n"
              "This is a bug in wbik, not in your input; run again with --debug for the traceback and "
              "report it.", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
