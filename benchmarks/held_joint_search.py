"""``analytic`` on the 7-joint arms of example-robot-data at its default options (one joint held and searched
over its range): how often it solves and what a solve costs, beside holding the start's value ("seed") and
the grid ("grid").

Per arm (a chain named by base and tip, as a user names it), --poses FK poses of seeded random joints inside
the limits, every solve from the chain's nominal configuration: the share solved by the shared check (all
calls), and the wall time of ``solve`` per call (median and 95th percentile over all calls, from
``time.perf_counter`` around the call). With --runs R the poses are solved R times and each figure is given
as the range over runs.

    .venv/bin/python benchmarks/held_joint_search.py [--poses 500] [--runs 3] [--modes search seed grid]
        [--arms "Alex right arm" ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import wbik

ARMS = (  # (label, robot, base, tip)
    ("Panda", "example-robot-data:panda", "panda_link0", "panda_link8"),
    ("Talos left arm", "example-robot-data:talos", "torso_2_link", "gripper_left_base_link"),
    ("Talos right arm", "example-robot-data:talos", "torso_2_link", "gripper_right_base_link"),
    ("iCub left arm", "example-robot-data:icub", "chest", "l_hand"),
    ("Romeo right arm", "example-robot-data:romeo", "torso", "r_wrist"),
    ("Tiago arm", "example-robot-data:tiago", "torso_lift_link", "arm_tool_link"),
    ("Tiago dual left arm", "example-robot-data:tiago_dual", "torso_lift_link", "arm_left_tool_link"),
    ("PR2 left arm", "example-robot-data:pr2", "torso_lift_link", "l_gripper_palm_link"),
    ("Alex right arm", "example-robot-data:alex_nub_hands", "Torso", "RightGripperYawLink"),
    ("Tiago Pro right arm", "example-robot-data:tiago_pro", "torso_lift_link", "arm_right_tool_link"),
)


def run_once(solver, targets) -> tuple[float, np.ndarray]:
    """(share solved, wall time per call (s)) of ``solve`` on every target from the nominal start."""
    solved, times = 0, np.empty(len(targets))
    nominal = solver.chain.nominal
    for index, target in enumerate(targets):
        began = time.perf_counter()
        result = solver.solve(target, q0=nominal)
        times[index] = time.perf_counter() - began
        solved += result.success
    return solved / len(targets), times


def span(values: list[float], scale: float = 1.0, digits: int = 3) -> str:
    low, high = min(values) * scale, max(values) * scale
    return f"{low:.{digits}g}" if f"{low:.{digits}g}" == f"{high:.{digits}g}" else \
        f"{low:.{digits}g}-{high:.{digits}g}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=500)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--modes", nargs="+", default=["search", "seed", "grid"],
                        choices=["search", "seed", "grid"])
    parser.add_argument("--arms", nargs="+", choices=[arm[0] for arm in ARMS], help="(default: every arm)")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.runs < 1:
        parser.error("--poses and --runs must be positive")
    print(f"{'arm':22s} {'mode':7s} {'solved %':>11s} {'median ms':>12s} {'p95 ms':>12s}  family")
    for label, name, base, tip in ARMS:
        if arguments.arms and label not in arguments.arms:
            continue
        robot = wbik.load(name)
        for mode in arguments.modes:
            solver = wbik.solver("analytic", robot, base=base, tip=tip, redundancy=mode)
            chain = solver.chain
            targets = [chain.fk(q) for q in chain.random(np.random.default_rng(0), arguments.poses)]
            shares, medians, tails = [], [], []
            for _ in range(arguments.runs):
                share, times = run_once(solver, targets)
                shares.append(share)
                medians.append(float(np.median(times)))
                tails.append(float(np.percentile(times, 95)))
            print(f"{label:22s} {mode:7s} {span(shares, 100, 4):>11s} {span(medians, 1e3):>12s} "
                  f"{span(tails, 1e3):>12s}  {solver.family}", flush=True)


if __name__ == "__main__":
    main()
