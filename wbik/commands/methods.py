"""List the IK methods that 'wbik solve --method' and study files accept, and whether each is installed."""

from __future__ import annotations

import argparse

HELP = "list the IK methods (and the extra to install for those whose library is missing)"


def run(args: argparse.Namespace) -> int:
    from wbik.solvers.method_registry import IK_METHOD_REGISTRY

    width = max(map(len, IK_METHOD_REGISTRY.entries()), default=0)
    for name, method in IK_METHOD_REGISTRY.entries().items():
        print(f"{name:{width}s}  {method.description}")
        if method.missing():
            print(f"{'':{width}s}  not installed: needs {method.needs.needs}; {method.needs.install}")
    return 0
