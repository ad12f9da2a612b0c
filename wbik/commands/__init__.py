"""Subcommands of the ``wbik`` CLI, one module each (see :mod:`wbik.cli`), and the arguments
several of them take."""

from __future__ import annotations

import argparse


def add_robot_arguments(parser: argparse.ArgumentParser) -> None:
    """ROBOT (a built-in name or a URDF path) and ``--chain`` (default: the robot's only chain)."""
    parser.add_argument("robot", help="built-in robot name (see 'wbik robots') or a URDF path")
    parser.add_argument("--chain", help="chain name (default: the robot's only chain)")


def add_json_argument(parser: argparse.ArgumentParser) -> None:
    """``--json``: print JSON instead of the text summary."""
    parser.add_argument("--json", action="store_true", help="print JSON")
