"""What `Solver.solve` costs besides the method itself: validation, timing, clipping, the shared FK
check and the IKResult, measured with a trivial method (it returns its start) and printed beside
one Pinocchio FK of the same chain, timed in the same process.

    .venv/bin/python benchmarks/interface_overhead.py [--calls 20000]

``ratios(quick)`` (for ``benchmarks/all.py``): per chain, the overhead against the issue's bound of
10 us per call (issue 16: "interface overhead <= 10 us per call"), and, informational, against one
Pinocchio FK of the same chain timed in the same process.
"""

from __future__ import annotations

import argparse
import sys
import timeit
from pathlib import Path

import numpy as np
import pinocchio as pin

import wbik
from wbik.solvers.base import Candidate
from wbik.solvers.base import Solver

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ratios import Ratio  # noqa: E402

BOUND_S = 10e-6
"""The issue's bound on the interface overhead per call."""

CHAINS = (("ur5", "arm"), ("golem3", "right_arm"), ("panda", "arm"), ("bioloid", "right_leg"),
          ("pincher", "arm"))


class Trivial(Solver):
    """Returns its start: what remains of `solve` is the interface alone."""

    name = "trivial"

    def _solve(self, target, q0, deadline):
        return Candidate(q0, 0)


def best_of(function, calls: int) -> float:
    """Seconds per call, best of 5 repeats (the least disturbed by other work on the machine)."""
    return min(timeit.repeat(function, number=calls, repeat=5)) / calls


def measure(robot_name: str, chain_name: str, calls: int) -> tuple[float, float, float]:
    """(solve, method, one FK) in seconds per call, best of 5 loops of ``calls``, for the trivial
    method on the chain's mid-range pose (so the shared check passes)."""
    robot = wbik.load(robot_name)
    chain = robot.chain(chain_name)
    solver = Trivial(robot, chain_name)
    q = chain.mid_range.copy()
    target = chain.fk(q)
    target_kind = wbik.as_target(target)
    solve = best_of(lambda: solver.solve(target, q), calls)
    method = best_of(lambda: solver._solve(target_kind, q, np.inf), calls)
    fk = best_of(lambda: pin.framesForwardKinematics(chain.model, chain.data, q), calls)
    return solve, method, fk


def ratios(quick: bool = False) -> list[Ratio]:
    """The overhead (solve - method) per chain against the 10 us bound and, informational, one FK."""
    calls = 2000 if quick else 20000
    note = f"trivial method, best of 5 loops of {calls} calls"
    found = []
    for robot_name, chain_name in CHAINS:
        solve, method, fk = measure(robot_name, chain_name, calls)
        overhead, name = solve - method, f"{robot_name}.{chain_name}"
        found.append(Ratio(f"interface overhead <= 10 us per call ({name})", "solve - method", overhead,
                           "the issue's bound", BOUND_S, "s/call", 1.0, "lower", note))
        found.append(Ratio(f"interface overhead / one FK ({name})", "solve - method", overhead,
                           "one Pinocchio framesForwardKinematics", fk, "s/call", None, "lower", note))
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calls", type=int, default=20000)
    args = parser.parse_args()
    print(f"{'chain':22s} {'solve (us)':>11s} {'method (us)':>12s} {'overhead (us)':>14s} "
          f"{'one FK (us)':>12s} {'overhead / FK':>14s}")
    for robot_name, chain_name in CHAINS:
        solve, method, fk = measure(robot_name, chain_name, args.calls)
        overhead = solve - method
        print(f"{robot_name + '.' + chain_name:22s} {solve * 1e6:11.2f} {method * 1e6:12.2f} "
              f"{overhead * 1e6:14.2f} {fk * 1e6:12.2f} {overhead / fk:14.1f}")
    print("overhead = solve - method: as_target (SE3 checked in plain floats), start joints, timing, "
          "clip into the limits, one FK, log3, the shared check and the IKResult.")


if __name__ == "__main__":
    main()
