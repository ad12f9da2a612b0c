"""List the built-in robots. With --verbose, load each and print its chains (base -> tip, joints)."""

from __future__ import annotations

import argparse

from wbik.commands.arguments import print_json

HELP = "list the built-in robots (and their chains with -v)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-v", "--verbose", action="store_true", help="load each robot and list its chains")
    parser.add_argument("--json", action="store_true", help="print JSON")


def run(args: argparse.Namespace) -> int:
    from wbik.models import load, robots

    listing = {}
    for name, description in robots().items():
        entry = {"description": description}
        if args.verbose:
            robot = load(name)
            entry["chains"] = {spec.name: {"base": spec.base_frame, "tip": spec.tip_frame,
                                           "joints": list(spec.joints)} for spec in robot.chains.values()}
        listing[name] = entry
    if args.json:
        return print_json(listing)
    for name, entry in listing.items():
        print(f"{name:10s} {entry['description']}")
        for chain, spec in entry.get("chains", {}).items():
            print(f"    chain {chain}: {spec['base']} -> {spec['tip']} ({len(spec['joints'])} joints: "
                  f"{', '.join(spec['joints'])})")
    return 0
