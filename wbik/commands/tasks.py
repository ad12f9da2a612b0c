"""List the scenario files shipped with wbik: name, kind and path. 'wbik run NAME' runs one from any
folder; copy its file to change it."""

from __future__ import annotations

import argparse

HELP = "list the scenario files shipped with wbik (run one with 'wbik run NAME')"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--paths", action="store_true", help="print only the file paths, one a line")


def run(args: argparse.Namespace) -> int:
    import yaml

    from wbik.data import data_dir, shipped_tasks

    tasks = shipped_tasks()
    if args.paths:
        for path in tasks.values():
            print(path)
        return 0
    print(f"{len(tasks)} tasks in {data_dir('tasks')} (run one: wbik run NAME)")
    width = max((len(name) for name in tasks), default=0)
    for name, path in tasks.items():
        try:
            kind = (yaml.safe_load(path.read_text(encoding="utf-8")) or {}).get("kind", "?")
        except (OSError, yaml.YAMLError, AttributeError):
            kind = "?"
        print(f"  {name:<{width}}  {kind}")
    return 0
