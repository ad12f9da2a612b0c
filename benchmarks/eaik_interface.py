"""What the ``eaik`` method costs per solve against EAIK's own call, in one process, on the same poses.

Chains: the UR10 of example-robot-data (ur10_robot.urdf, world -> tool0) and the UR5's ``ee`` chain.
Targets: FK poses of random joints inside the limits (seeded); every ``solve`` starts from the chain's
nominal configuration. Rows, wall time per pose, each the best of interleaved rounds (every row once
per round, as the other benchmarks):

* EAIK IK: ``eaik.IK_HP.HPRobot(H, P).IK(pose)``, every branch, on poses already in EAIK's frame (the
  reference of the ratio: EAIK's own call, no limits, no choice, no check);
* eaik solve: ``wbik.solver("eaik", ...).solve(pose)``, everything included (the target's checks, EAIK's
  call, wrapping into the limits, the nearest branch that passes the FK screen, the shared check, the
  IKResult);
* interface: ``Solver.solve`` with a method that returns its start (what a method without its own
  ``solve`` pays: target conversion, timing, the shared check with Pinocchio's FK, the IKResult;
  ``interface_overhead.py``'s measurement). For comparison only: the ``eaik`` method's own ``solve``
  checks the target once and hands the shared check the errors its choice computed (no second FK).

    .venv/bin/python benchmarks/eaik_interface.py [--poses 2000] [--rounds 9] [--runs 3]

Each run prints the rows and the ratios eaik solve / EAIK IK and interface / EAIK IK; with --runs N the
ranges over the runs close the output.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

import wbik
from wbik.solvers.base import Solver
from wbik.solvers.result import Candidate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ratios import (
    Ratio,  # noqa: E402
    best_of_rounds,  # noqa: E402
)

ROUNDS = 9
GOAL = 1.5
"""The goal: the ``eaik`` method costs at most 1.5x EAIK's own call per solve."""


class Trivial(Solver):
    """Returns its start: the interface alone."""

    name = "trivial"

    def _solve(self, target, q0, deadline):
        return Candidate(q0, 0)


def ur10() -> wbik.Robot:
    from wbik.models.erd import urdf_path

    return wbik.load(str(urdf_path("ur_description/urdf/ur10_robot.urdf")))


def rows_of(label: str, robot: wbik.Robot, chain: str | None, count: int,
            seed: int) -> dict[str, tuple[Callable[[], object], int]]:
    """The timed loops of one chain: EAIK's own call, the eaik solve, the interface alone."""
    from eaik.IK_HP import HPRobot

    solver = wbik.solver("eaik", robot, chain)
    trivial = Trivial(robot, chain)
    chain_ = solver.chain
    poses = [chain_.fk(q) for q in chain_.random(np.random.default_rng(seed), count)]
    eaik_poses = [solver.eaik_pose(wbik.targets.as_target(pose)) for pose in poses]
    own = HPRobot(solver.structure.H, solver.structure.P)
    nominal = chain_.nominal
    middle = chain_.fk(nominal)
    for run in (lambda: own.IK(eaik_poses[0]), lambda: solver.solve(poses[0]), lambda: trivial.solve(middle)):
        run()  # first-call costs out of the timings
    return {
        f"{label} EAIK IK": (lambda: [own.IK(pose) for pose in eaik_poses], count),
        f"{label} eaik solve": (lambda: [solver.solve(pose) for pose in poses], count),
        f"{label} interface": (lambda: [trivial.solve(middle, nominal) for _ in poses], count),
    }


def measure(count: int, rounds: int, seed: int = 0) -> dict[str, tuple[float, object]]:
    """{row: (seconds per pose, the last run's output)} for both chains, interleaved."""
    rows = {**rows_of("UR10", ur10(), None, count, seed),
            **rows_of("UR5 ee", wbik.load("ur5"), "ee", count, seed)}
    outputs: dict[str, object] = {}

    def timed(label: str, run: Callable[[], object], items: int) -> Callable[[], float]:
        def seconds_per_item() -> float:
            start = time.perf_counter()
            outputs[label] = run()
            return (time.perf_counter() - start) / items
        return seconds_per_item

    best = best_of_rounds({label: timed(label, run, items) for label, (run, items) in rows.items()}, rounds)
    return {label: (best[label], outputs[label]) for label in rows}


def report(rows: dict[str, tuple[float, object]], count: int) -> dict[str, tuple[float, float]]:
    """Print the rows; return (eaik solve, interface) / EAIK IK per chain."""
    ratios = {}
    for chain in ("UR10", "UR5 ee"):
        own, solve, interface = (rows[f"{chain} {row}"][0] for row in ("EAIK IK", "eaik solve", "interface"))
        solved = sum(result.success for result in rows[f"{chain} eaik solve"][1])
        ratios[chain] = (solve / own, interface / own)
        print(f"{chain}: EAIK IK {own * 1e6:6.2f} us | eaik solve {solve * 1e6:6.2f} us ({solved}/{count} "
              f"solved) = {solve / own:5.2f} x EAIK | a trivial method through Solver.solve "
              f"{interface * 1e6:5.2f} us = {interface / own:4.2f} x EAIK")
    return ratios


def ratios(quick: bool = False) -> list[Ratio]:
    """The eaik method's solve against EAIK's own call on the UR10 and the UR5, same run."""
    count, rounds = (300, 3) if quick else (2000, ROUNDS)
    rows = measure(count, rounds)
    result = []
    for chain in ("UR10", "UR5 ee"):
        own, solve, interface = (rows[f"{chain} {row}"][0] for row in ("EAIK IK", "eaik solve", "interface"))
        result.append(Ratio(
            f"{chain} eaik method solve <= 1.5x EAIK's own call", f"eaik solve ({chain})", solve,
            "EAIK HPRobot.IK (all branches)", own, "s/pose", GOAL,
            note=(f"{count} FK poses from the nominal start, best of {rounds} interleaved rounds; ours with "
                  f"everything (target checks, limits, choice, FK screen, shared check, IKResult); a "
                  f"trivial method through Solver.solve costs {interface * 1e6:.1f} us = "
                  f"{interface / own:.2f}x EAIK's call")))
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--runs", type=int, default=1, help="independent runs; the ratio's range closes")
    arguments = parser.parse_args(argv)
    if min(arguments.poses, arguments.rounds, arguments.runs) < 1:
        parser.error("--poses, --rounds and --runs must be positive")
    print(f"{arguments.poses} FK poses per chain, best of {arguments.rounds} interleaved rounds, "
          "wall per pose")
    found: dict[str, list[tuple[float, float]]] = {}
    for run in range(arguments.runs):
        print(f"run {run + 1}:")
        rows = measure(arguments.poses, arguments.rounds, seed=run)
        for chain, ratio in report(rows, arguments.poses).items():
            found.setdefault(chain, []).append(ratio)
    for chain, values in found.items():
        solves, interfaces = zip(*values, strict=True)
        print(f"{chain}: eaik solve / EAIK IK from {min(solves):.2f} to {max(solves):.2f} over {len(values)} "
              f"run(s) (goal <= {GOAL:g}); a trivial method through Solver.solve from "
              f"{min(interfaces):.2f} to {max(interfaces):.2f}")


if __name__ == "__main__":
    main()
