"""``wbik methods``: the registered IK methods."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser("methods", help="list the IK methods", description="List the IK methods "
                                   "that 'wbik solve --method' and study files accept.")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import wbik

    for name, description in wbik.methods().items():
        print(f"{name:12s} {description}")
    return 0
