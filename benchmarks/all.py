"""Every speed goal of wbik as a ratio to a peer measured in the same process and run.

    .venv/bin/python benchmarks/all.py                 # full run (several minutes)
    .venv/bin/python benchmarks/all.py --quick         # smaller samples (about two minutes)
    .venv/bin/python benchmarks/all.py --only qp --json runs/bench.json

Runs, in one process and one after the other, the ``ratios()`` of each benchmark module
(interface overhead, closed forms vs EAIK, the eaik method vs EAIK's own call, numerical IK vs
TRAC-IK, whole-body QP vs PlaCo and Pink) and prints one table: ours, the peer, the ratio and
whether wbik's goal is met. Times are wall clock on this machine; the ratios are what carries
over to another machine, so the README quotes them. The machine and its load are printed first: a
loaded machine distorts the ratios (each benchmark interleaves ours and the peer and keeps the best
of several loops to limit that).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import closed_forms_vs_eaik  # noqa: E402
import eaik_interface  # noqa: E402
import interface_overhead  # noqa: E402
import numerical  # noqa: E402
import qp  # noqa: E402
from ratios import Ratio  # noqa: E402

BENCHMARKS = {  # name -> module in benchmarks/ with ratios(quick)
    "overhead": interface_overhead,
    "closed_forms": closed_forms_vs_eaik,
    "eaik": eaik_interface,
    "numerical": numerical,
    "qp": qp,
}


def interpreter_probe(additions: int = 1_000_000, rounds: int = 5) -> float:
    """Seconds for ``additions`` integer additions in a Python loop, best of ``rounds``: how fast this
    machine runs the interpreter, the part of our time that no compiled peer has. Ratios to compiled peers
    move with it (docs/benchmarks.md), so a run is read beside its probe."""
    best = math.inf
    for _ in range(rounds):
        started, total = time.perf_counter(), 0
        for value in range(additions):
            total += value
        best = min(best, time.perf_counter() - started)
    return best


def machine() -> dict:
    """What the figures were measured on (``python_loop_s``: :func:`interpreter_probe`)."""
    import numpy
    import pinocchio

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as handle:
            cpu = next(line.split(":", 1)[1].strip() for line in handle if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numpy": numpy.__version__, "pinocchio": pinocchio.__version__,
            "load_average": [round(value, 2) for value in os.getloadavg()],
            "python_loop_s": round(interpreter_probe(), 4)}


def _figure(value: float, unit: str) -> str:
    if unit.startswith("s/"):
        return f"{value * 1e6:10.1f} us" if value < 1e-3 else f"{value * 1e3:10.2f} ms"
    if unit == "fraction":
        return f"{100.0 * value:10.2f} %"
    return f"{value:10.0f} {unit}"


def format_table(results: list[tuple[str, Ratio]]) -> str:
    lines = [f"{'goal':<46} {'ours':>13} {'peer':>13} {'ratio':>7}  verdict",
             "-" * 100]
    for name, ratio in results:
        lines.append(f"{ratio.goal[:46]:<46} {_figure(ratio.ours, ratio.unit):>13} "
                     f"{_figure(ratio.peer, ratio.unit):>13} {ratio.ratio:7.2f}  {ratio.verdict()}")
        lines.append(f"    [{name}] ours: {ratio.ours_label}; peer: {ratio.peer_label}"
                     + (f"; {ratio.note}" if ratio.note else ""))
    return "\n".join(lines)


def run(names: list[str], quick: bool) -> list[tuple[str, Ratio]]:
    results: list[tuple[str, Ratio]] = []
    for name in names:
        module = BENCHMARKS[name]
        started = time.perf_counter()
        ratios = module.ratios(quick=quick)
        if not ratios or not all(isinstance(ratio, Ratio) for ratio in ratios):
            raise TypeError(f"{module.__name__}.ratios() must return a non-empty list of Ratio")
        print(f"  {name}: {len(ratios)} ratios in {time.perf_counter() - started:.1f} s", file=sys.stderr)
        results.extend((name, ratio) for ratio in ratios)
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller samples (a smoke run)")
    parser.add_argument("--only", nargs="+", choices=sorted(BENCHMARKS), default=list(BENCHMARKS),
                        help="run only these benchmarks")
    parser.add_argument("--json", type=Path, default=None, help="also write the ratios here")
    arguments = parser.parse_args(argv)
    facts = machine()
    print(f"machine: {facts['cpu']}, {facts['cores']} cores, Python {facts['python']}, "
          f"NumPy {facts['numpy']}, Pinocchio {facts['pinocchio']}, load {facts['load_average']}, "
          f"1M Python additions in {facts['python_loop_s'] * 1e3:.0f} ms")
    results = run(arguments.only, arguments.quick)
    print(format_table(results))
    goals = [ratio.met for _, ratio in results if ratio.met is not None]
    spared = [ratio.spared for _, ratio in results if ratio.met is not None]
    print(f"\n{sum(goals)} of {len(goals)} goals met, {sum(spared)} of them with 25 % to spare "
          f"({len(results) - len(goals)} informational rows)")
    if arguments.json:
        arguments.json.parent.mkdir(parents=True, exist_ok=True)
        rows = [dict(vars(ratio), benchmark=name, ratio=ratio.ratio, met=ratio.met, spared=ratio.spared)
                for name, ratio in results]
        document = {"machine": facts, "quick": arguments.quick, "ratios": rows}
        temporary = arguments.json.with_suffix(".tmp")
        temporary.write_text(json.dumps(document, indent=1))
        temporary.replace(arguments.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
