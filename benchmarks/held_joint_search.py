"""``analytic`` on the 7-joint arms of example-robot-data at its default options (one joint held and searched
over its range): how often it solves and what a solve costs, beside holding the start's value ("seed") and
the grid ("grid"); and on the arms no family or EAIK decomposition solves (the search-based forms, or the
refusal's reason).

Per arm (a chain named by base and tip, as a user names it), --poses FK poses of seeded random joints inside
the limits, every solve from the chain's nominal configuration: the share solved by the shared check (all
calls), the wall time of ``solve`` per call (median and 95th percentile over all calls, from
``time.perf_counter`` around the call) and the branches per solved call. With --runs R the poses are solved R
times and each figure is given as the range over runs. A 6-joint arm has one row (nothing is held).

    .venv/bin/python benchmarks/held_joint_search.py [--poses 500] [--runs 3] [--modes search seed grid]
        [--arms held search]
"""

from __future__ import annotations

import argparse
import re
import time

import numpy as np

import wbik
from wbik.errors import UnsupportedError

ARMS = (  # (label, robot, base, tip)
    ("Panda", "example-robot-data:panda", "panda_link0", "panda_link8"),
    ("Talos left arm", "example-robot-data:talos", "torso_2_link", "gripper_left_base_link"),
    ("Talos right arm", "example-robot-data:talos", "torso_2_link", "gripper_right_base_link"),
    ("iCub left arm", "example-robot-data:icub", "chest", "l_hand"),
    ("Romeo right arm", "example-robot-data:romeo", "torso", "r_wrist"),
    ("Tiago arm", "example-robot-data:tiago", "torso_lift_link", "arm_tool_link"),
    ("Tiago dual left arm", "example-robot-data:tiago_dual", "torso_lift_link", "arm_left_tool_link"),
    ("PR2 left arm", "example-robot-data:pr2", "torso_lift_link", "l_gripper_palm_link"),
)
SEARCH_ARMS = (  # no family or EAIK decomposition, held joint or not (the zoo's base and tip)
    ("Bravo 7", "example-robot-data:bravo7_no_ee", "link1", "end_effector_ball"),
    ("Baxter right arm", "example-robot-data:baxter", "torso", "right_gripper_base_link"),
    ("Alex right arm", "example-robot-data:alex_nub_hands", "Torso", "RightGripperYawLink"),
    ("Tiago Pro right arm", "example-robot-data:tiago_pro", "torso_lift_link", "arm_right_tool_link"),
)


def run_once(solver, targets) -> tuple[float, np.ndarray, float]:
    """(share solved, wall time per call (s), branches per solved call) of ``solve`` on every target from
    the nominal start."""
    solved, times, branches = 0, np.empty(len(targets)), 0
    nominal = solver.chain.nominal
    for index, target in enumerate(targets):
        began = time.perf_counter()
        result = solver.solve(target, q0=nominal)
        times[index] = time.perf_counter() - began
        solved += result.success
        branches += result.extra.get("branches", 0) if result.success else 0
    return solved / len(targets), times, branches / max(solved, 1)


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
    parser.add_argument("--arms", nargs="+", default=["held", "search"], choices=["held", "search"],
                        help="the 7-joint arms a family or EAIK solves with a joint held, the arms without")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.runs < 1:
        parser.error("--poses and --runs must be positive")
    arms = (ARMS if "held" in arguments.arms else ()) + (SEARCH_ARMS if "search" in arguments.arms else ())
    print(f"{'arm':22s} {'mode':7s} {'solved %':>11s} {'median ms':>12s} {'p95 ms':>12s} {'branches':>9s}  "
          "family")
    for label, name, base, tip in arms:
        robot = wbik.load(name)
        for mode in arguments.modes:
            try:
                solver = wbik.solver("analytic", robot, base=base, tip=tip, redundancy=mode)
            except UnsupportedError as refused:
                why = re.search(r"search: neither.*?in all", str(refused))  # the search's reason
                reason = why.group(0) if why else str(refused)
                print(f"{label:22s} {mode:7s} {'refused':>11s}  {reason}", flush=True)
                break
            chain = solver.chain
            targets = [chain.fk(q) for q in chain.random(np.random.default_rng(0), arguments.poses)]
            shares, medians, tails, branches = [], [], [], []
            for _ in range(arguments.runs):
                share, times, per_call = run_once(solver, targets)
                shares.append(share)
                medians.append(float(np.median(times)))
                tails.append(float(np.percentile(times, 95)))
                branches.append(per_call)
            print(f"{label:22s} {mode:7s} {span(shares, 100, 4):>11s} {span(medians, 1e3):>12s} "
                  f"{span(tails, 1e3):>12s} {span(branches):>9s}  {solver.family}", flush=True)
            if chain.nq < 7:
                break  # nothing is held: the modes are one


if __name__ == "__main__":
    main()
