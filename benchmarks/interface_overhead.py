"""What `Solver.solve` costs besides the method itself: validation, timing, clipping, the shared FK
check and the IKResult, measured with a trivial method (it returns its start) and printed beside
one Pinocchio FK of the same chain, timed in the same process.

    .venv/bin/python benchmarks/interface_overhead.py [--calls 5000] [--rounds 15] [--phases]

``--phases`` adds where one trivial ``solve`` of each chain spends its microseconds: each step of the
path timed alone on the same inputs (best of the rounds), and the rest (Python between them: calls,
attribute reads, the branch tests).

``ratios(quick)`` (for ``benchmarks/all.py``): per chain, the overhead against wbik's bound of
5 us per call ("interface overhead <= 5 us per call"), and, informational, against one
Pinocchio FK of the same chain timed in the same process.
"""

from __future__ import annotations

import argparse
import sys
import time
import timeit
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

import wbik
from wbik.solvers.base import Solver
from wbik.solvers.check import evaluate
from wbik.solvers.result import Candidate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ratios import (
    Ratio,  # noqa: E402
    best_of_rounds,  # noqa: E402
)

BOUND_S = 5e-6
"""wbik's bound on the interface overhead per call."""

CHAINS = (("ur5", "arm"), ("golem3", "right_arm"), ("panda", "arm"), ("bioloid", "right_leg"),
          ("pincher", "arm"))


class Trivial(Solver):
    """Returns its start: what remains of `solve` is the interface alone."""

    name = "trivial"

    def _solve(self, target, q0, deadline):
        return Candidate(q0, 0)


ROUNDS = 15
"""Interleaved rounds: every chain's three loops run once per round, and each keeps its best round. This
machine has slow phases of a second or more (a loop then took up to 1.6x as long); five loops in a row
could all fall inside one, while fifteen rounds spread over all chains rarely do."""


PHASES = ("as_target", "start joints (check_q)", "the clock (2 perf_counter)", "the method",
          "the check (evaluate: limits, FK, errors, IKResult)")
"""The steps of a chain target's ``solve`` with the trivial method, in order (``--phases``)."""
LABEL = 52
"""The width of the phase table's first column."""


def chain_loops(robot_name: str, chain_name: str) -> dict[str, Callable[[], object]]:
    """One chain's timed loop bodies on its mid-range pose (so the shared check passes): ``solve`` (the
    trivial method through the interface), ``method`` (the trivial method alone), ``fk`` (one Pinocchio
    framesForwardKinematics) and each of :data:`PHASES` alone."""
    robot = wbik.load(robot_name)
    chain = robot.chain(chain_name)
    solver = Trivial(robot, chain_name)
    q = chain.mid_range.copy()
    target = chain.fk(q)
    kind = wbik.as_target(target)
    candidate = Candidate(q, 0)
    tolerances = solver.tolerances
    clock = time.perf_counter

    def method() -> Candidate:
        return solver._solve(kind, q, np.inf)

    phases = (lambda: wbik.as_target(target), lambda: chain.check_q(q), lambda: (clock(), clock()), method,
              lambda: evaluate(chain, kind, candidate, tolerances, 0.0, solver.name))
    return {"solve": lambda: solver.solve(target, q), "method": method,
            "fk": lambda: pin.framesForwardKinematics(chain.model, chain.data, q),
            **dict(zip(PHASES, phases, strict=True))}


def measure(calls: int, rounds: int = ROUNDS, labels: tuple[str, ...] = ("solve", "method", "fk")
            ) -> dict[str, dict[str, float]]:
    """{chain: {label: seconds per call}} for the :func:`chain_loops` named by ``labels``: each loop's best
    over ``rounds`` interleaved rounds of ``calls`` calls (every loop of every chain once per round)."""
    loops = {(f"{robot}.{chain}", label): body for robot, chain in CHAINS
             for label, body in chain_loops(robot, chain).items() if label in labels}
    best = best_of_rounds({key: (lambda body=body: timeit.timeit(body, number=calls) / calls)
                           for key, body in loops.items()}, rounds)
    found: dict[str, dict[str, float]] = {}
    for (name, label), seconds in best.items():
        found.setdefault(name, {})[label] = seconds
    return found


def ratios(quick: bool = False) -> list[Ratio]:
    """The overhead (solve - method) per chain against the 5 us bound and, informational, one FK."""
    calls, rounds = (2000, 5) if quick else (5000, ROUNDS)
    note = f"trivial method, best of {rounds} interleaved rounds of {calls} calls"
    found = []
    for name, times in measure(calls, rounds).items():
        overhead = times["solve"] - times["method"]
        found.append(Ratio(f"interface overhead <= 5 us per call ({name})", "solve - method", overhead,
                           "the 5 us bound", BOUND_S, "s/call", 1.0, "lower", note))
        found.append(Ratio(f"interface overhead / one FK ({name})", "solve - method", overhead,
                           "one Pinocchio framesForwardKinematics", times["fk"], "s/call", None, "lower",
                           note))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calls", type=int, default=5000, help="calls per loop and round")
    parser.add_argument("--rounds", type=int, default=ROUNDS,
                        help="interleaved rounds; each loop keeps its best")
    parser.add_argument("--phases", action="store_true",
                        help="also time each step of a trivial solve alone (where the microseconds go)")
    args = parser.parse_args()
    print(f"{'chain':22s} {'solve (us)':>11s} {'method (us)':>12s} {'overhead (us)':>14s} "
          f"{'one FK (us)':>12s} {'overhead / FK':>14s}")
    for name, times in measure(args.calls, args.rounds).items():
        solve, method, fk = times["solve"], times["method"], times["fk"]
        overhead = solve - method
        print(f"{name:22s} {solve * 1e6:11.2f} {method * 1e6:12.2f} "
              f"{overhead * 1e6:14.2f} {fk * 1e6:12.2f} {overhead / fk:14.1f}")
    print("overhead = solve - method: as_target (SE3 checked in plain floats), start joints, timing, "
          "clip into the limits, one FK, log3, the shared check and the IKResult.")
    if args.phases:
        print(f"\nwhere one trivial solve's time goes (us, each step alone, best of {args.rounds} rounds):")
        timings = measure(args.calls, args.rounds, ("solve", *PHASES))
        names = list(timings)
        print(f"{'step':{LABEL}s}" + "".join(f"{name:>19s}" for name in names))
        for label in (*PHASES, "rest (Python between the steps)", "solve"):
            values = [timings[name]["solve"] - sum(timings[name][p] for p in PHASES)
                      if label.startswith("rest") else timings[name][label] for name in names]
            print(f"{label:{LABEL}s}" + "".join(f"{value * 1e6:19.2f}" for value in values))


if __name__ == "__main__":
    main()
