"""The arguments several subcommands of the ``wbik`` command take (a robot and its chain, ``--json``)."""

from __future__ import annotations

import argparse
import json

from wbik.errors import UsageError
from wbik.files import json_plain


def add_robot_arguments(parser: argparse.ArgumentParser) -> None:
    """ROBOT and its chain: ``--chain`` (default: the only one) or ``--base`` and ``--tip``."""
    parser.add_argument("robot", help="built-in robot name (see 'wbik robots'), example-robot-data:NAME "
                        "(e.g. example-robot-data:talos) or a URDF path")
    parser.add_argument("--chain", help="chain name (default: the robot's only chain)")
    parser.add_argument("--base", help="base frame of the chain (with --tip; instead of --chain)")
    parser.add_argument("--tip", help="tip frame of the chain (with --base; instead of --chain)")


def load_robot_chain(args: argparse.Namespace):
    """(robot, chain) named by ROBOT and ``--chain`` or ``--base``/``--tip`` (else a UsageError)."""
    from wbik.models import load

    base, tip = getattr(args, "base", None), getattr(args, "tip", None)
    if (base is None) != (tip is None):
        raise UsageError("give both --base and --tip (a chain from one frame to the other), or --chain")
    if base is not None and args.chain is not None:
        raise UsageError("give either --chain or --base and --tip, not both")
    robot = load(args.robot)
    chain = robot.chain_between(base, tip) if base is not None else robot.chain(args.chain)
    return robot, chain


def print_json(data) -> int:
    """Print ``data`` as indented JSON (NumPy values made plain); 0, the exit code of a printed answer."""
    print(json.dumps(json_plain(data), indent=2))
    return 0
