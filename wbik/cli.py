"""The ``wbik`` command. Each subcommand lives in ``wbik/commands/<name>.py`` with
``add_parser(subparsers)`` and ``run(args) -> int``; heavy imports stay inside ``run``."""

from __future__ import annotations

import argparse
import importlib
import sys

from wbik.errors import WbikError

SUBCOMMANDS = ("robots", "methods", "fk", "solve", "study", "view", "run")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wbik",
        description="Whole-body inverse kinematics: every IK method behind one interface, on Pinocchio.",
        epilog="Units: metres and radians unless an option names degrees. "
               "Run 'wbik COMMAND --help' for each command.")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        try:
            module = importlib.import_module(f"wbik.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"wbik.commands.{name}":
                raise
            continue
        module.add_parser(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return int(args.run(args) or 0)
    except WbikError as exc:
        print(f"wbik {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
