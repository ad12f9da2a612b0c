"""List the IK methods that 'wbik solve --method' and study files accept."""

from __future__ import annotations

import argparse

HELP = "list the IK methods"


def run(args: argparse.Namespace) -> int:
    from wbik.solvers.method_registry import methods

    for name, description in methods().items():
        print(f"{name:12s} {description}")
    return 0
