"""What `Solver.solve` costs besides the method itself: validation, timing, clipping, the shared FK
check and the IKResult, measured with a trivial method (it returns its start) and printed beside
one Pinocchio FK of the same chain, timed in the same process.

    .venv/bin/python benchmarks/interface_overhead.py [--calls 20000]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np
import pinocchio as pin

import wbik
from wbik.solvers.base import Candidate, Solver

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calls", type=int, default=20000)
    args = parser.parse_args()
    print(f"{'chain':22s} {'solve (us)':>11s} {'method (us)':>12s} {'overhead (us)':>14s} "
          f"{'one FK (us)':>12s} {'overhead / FK':>14s}")
    for robot_name, chain_name in CHAINS:
        robot = wbik.load(robot_name)
        chain = robot.chain(chain_name)
        solver = Trivial(robot, chain_name)
        q = chain.mid_range.copy()
        target = chain.fk(q)
        target_kind = wbik.as_target(target)
        solve = best_of(lambda: solver.solve(target, q), args.calls)  # noqa: B023 - timed at once
        method = best_of(lambda: solver._solve(target_kind, q, np.inf), args.calls)  # noqa: B023
        fk = best_of(lambda: pin.framesForwardKinematics(chain.model, chain.data, q), args.calls)  # noqa: B023
        overhead = solve - method
        print(f"{robot_name + '.' + chain_name:22s} {solve * 1e6:11.2f} {method * 1e6:12.2f} "
              f"{overhead * 1e6:14.2f} {fk * 1e6:12.2f} {overhead / fk:14.1f}")
    print("overhead = solve - method: as_target (SE3 checked in plain floats), start joints, timing, "
          "clip into the limits, one FK, log3, the shared check and the IKResult.")


if __name__ == "__main__":
    main()
