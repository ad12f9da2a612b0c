"""Benchmark of every closed form of every built-in robot: scalar and batched solve time, success rate.

Robots and chains are discovered, not listed: every robot of ``wbik.robots()`` that loads, and every
(chain, kind) its ``robot.closed_forms`` declares. Targets are FK poses (or positions, for
position closed forms) of random joints inside the limits (seeded); every solve starts from the chain's
nominal configuration.

Columns: scalar ``solve`` wall time per pose (median and 95th percentile, over --scalar-poses targets),
``solve_many`` wall time per pose on --poses targets (the whole call, including the shared Pinocchio FK
check of every result) and the closed-form part alone, success rates of both, mean real branches per target.

    .venv/bin/python benchmarks/analytic.py                  # all robots, 10,000 poses
    .venv/bin/python benchmarks/analytic.py --poses 2000 --robots ur5 pincher --output analytic.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import wbik


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=10_000, help="targets per chain for solve_many")
    parser.add_argument("--scalar-poses", type=int, default=1000,
                        help="targets per chain timed one by one with solve (at most --poses)")
    parser.add_argument("--robots", nargs="+", default=None, help="robot names (default: every built-in)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the sampled joints")
    parser.add_argument("--output", type=Path, default=None,
                        help="append one JSON line per chain here as soon as it is measured")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.scalar_poses < 1:
        parser.error("--poses and --scalar-poses must be positive")
    unknown = sorted(set(arguments.robots or ()) - set(wbik.robots()))
    if unknown:
        parser.error(f"unknown robots {unknown}; built-in robots: {', '.join(wbik.robots())}")
    return arguments


def targets_for(chain, kind: str, joints: np.ndarray) -> list:
    """FK poses of the joints (Pinocchio), or their positions for position closed forms."""
    poses = [chain.fk(q) for q in joints]
    return poses if kind == "pose" else [pose.translation.copy() for pose in poses]


def time_solver(solver, targets: list, scalar_poses: int) -> dict:
    """Scalar ``solve`` on the first ``scalar_poses`` targets and one ``solve_many`` on all of them.

    Timings in microseconds per pose (wall time), success rates in percent.
    """
    solver.solve(targets[0])  # import and first-call costs out of the timings
    scalar_times, scalar_successes = [], []
    for target in targets[:scalar_poses]:
        start = time.perf_counter()
        result = solver.solve(target)
        scalar_times.append(time.perf_counter() - start)
        scalar_successes.append(result.success)
    start = time.perf_counter()
    results = solver.solve_many(targets)
    batch_time = time.perf_counter() - start
    micro = 1e6
    return {
        "scalar_median_us": float(np.median(scalar_times)) * micro,
        "scalar_p95_us": float(np.percentile(scalar_times, 95)) * micro,
        "scalar_success_pct": 100.0 * float(np.mean(scalar_successes)),
        "batch_poses": len(targets),
        "batch_us_per_pose": batch_time / len(targets) * micro,
        "closed_form_us_per_pose": results[0].time_s * micro,
        "batch_success_pct": 100.0 * float(np.mean([r.success for r in results])),
        "branches_mean": float(np.mean([r.extra.get("branches", 0) for r in results])),
    }


def measure(robot, chain_name: str, kind: str, poses: int, scalar_poses: int, seed: int) -> dict:
    """One table row for a chain: targets from FK of seeded random joints inside the limits."""
    solver = wbik.solver("analytic", robot, chain=chain_name)
    chain = solver.chain
    targets = targets_for(chain, kind, chain.random(np.random.default_rng(seed), poses))
    return {"robot": robot.name, "chain": chain_name, "kind": kind, "joints": chain.nq,
            **time_solver(solver, targets, scalar_poses)}


HEADER = (f"{'robot':<10} {'chain':<16} {'kind':<8} {'n':>2} {'solve med us':>12} {'p95 us':>8} "
          f"{'ok %':>7} {'many us/pose':>12} {'cf us/pose':>10} {'ok %':>7} {'branches':>8}")


def format_row(row: dict) -> str:
    return (f"{row['robot']:<10} {row['chain']:<16} {row['kind']:<8} {row['joints']:>2} "
            f"{row['scalar_median_us']:>12.1f} {row['scalar_p95_us']:>8.1f} "
            f"{row['scalar_success_pct']:>7.2f} "
            f"{row['batch_us_per_pose']:>12.2f} {row['closed_form_us_per_pose']:>10.2f} "
            f"{row['batch_success_pct']:>7.2f} {row['branches_mean']:>8.2f}")


def main(argv: list[str] | None = None) -> int:
    arguments = parse_arguments(argv)
    names = arguments.robots or list(wbik.robots())
    print(f"analytic closed forms: {arguments.poses} poses per chain for solve_many, "
          f"{min(arguments.scalar_poses, arguments.poses)} timed one by one; seed {arguments.seed}")
    print("solve: scalar wall time per pose; many: solve_many wall time per pose (with the shared FK "
          "check); cf: its closed-form part; branches: mean real closed-form branches per target (before "
          "limits and screening)")
    print(HEADER)
    print("-" * len(HEADER))
    skipped = []
    for name in names:
        try:
            robot = wbik.load(name)
        except (ImportError, wbik.WbikError) as exc:  # robots being written elsewhere may not load yet
            skipped.append(f"{name}: does not load ({type(exc).__name__}: {exc})")
            continue
        forms = robot.closed_forms
        if not forms:
            skipped.append(f"{name}: declares no closed form")
            continue
        for chain_name, kind in sorted(forms):
            try:
                row = measure(robot, chain_name, kind, arguments.poses,
                              min(arguments.scalar_poses, arguments.poses), arguments.seed)
            except (ImportError, wbik.WbikError) as exc:
                skipped.append(f"{name}.{chain_name} ({kind}): {type(exc).__name__}: {exc}")
                continue
            print(format_row(row), flush=True)
            if arguments.output is not None:
                with arguments.output.open("a") as stream:
                    stream.write(json.dumps(row) + "\n")
    for line in skipped:
        print("skipped", line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
