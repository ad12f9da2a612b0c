"""How long a fresh Python process takes to ``import wbik`` and to print ``wbik --help``.

    .venv/bin/python benchmarks/import_time.py             # 15 rounds
    .venv/bin/python benchmarks/import_time.py --rounds 40

Each round starts, one after the other, a fresh interpreter for: ``import numpy, pinocchio`` (the
floor: what wbik cannot import less than), ``import wbik``, and ``wbik --help``. The wall time of a
whole process is measured (start-up included); the table gives the best and the median over the
rounds and what wbik adds to the floor. Goals: ``import wbik`` at most 0.5 s and ``wbik --help`` at
most 0.8 s on a machine like the reference one (docs/benchmarks.md), both met with 25 % to spare
(0.4 s and 0.6 s at the median); what each import pulls in is held by tests/test_packaging.py.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

GOALS_S = {"import wbik": 0.5, "wbik --help": 0.8}
SPARE = 0.75  # a goal counts as met at 75 % of its bound (another machine of the kind ran 1.5x slower)


def commands() -> dict[str, list[str]]:
    """The three processes, by label."""
    python = sys.executable
    cli = Path(python).with_name("wbik")
    return {"import numpy, pinocchio": [python, "-c", "import numpy, pinocchio"],
            "import wbik": [python, "-c", "import wbik"],
            "wbik --help": [str(cli), "--help"] if cli.exists() else [python, "-m", "wbik.cli", "--help"]}


def wall_time(command: list[str]) -> float:
    """The wall time of one run of ``command`` (s); its output is discarded."""
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def measure(rounds: int) -> dict[str, list[float]]:
    """Every command's times over ``rounds`` interleaved rounds (a slow phase hits all alike)."""
    runs = commands()
    for command in runs.values():  # one warm-up each: the first run also fills the OS's file cache
        wall_time(command)
    times: dict[str, list[float]] = {label: [] for label in runs}
    for _ in range(rounds):
        for label, command in runs.items():
            times[label].append(wall_time(command))
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15, help="fresh processes per command (default 15)")
    args = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; {args.rounds} rounds")
    times = measure(args.rounds)
    floor = statistics.median(times["import numpy, pinocchio"])
    print(f"{'process':26s} {'best':>8s} {'median':>8s} {'over floor':>11s}  goal")
    for label, values in times.items():
        best, median = min(values), statistics.median(values)
        goal = GOALS_S.get(label)
        verdict = "" if goal is None else (
            f"<= {goal:.1f} s: {'met' if median <= SPARE * goal else 'MISSED'} with 25 % to spare")
        print(f"{label:26s} {best:7.3f}s {median:7.3f}s {median - floor:+10.3f}s  {verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
