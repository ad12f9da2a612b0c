"""Speed and success of the Golem-III closed forms, beside the thesis' figures (golem3.md ch. 5).

    .venv/bin/python benchmarks/analytic_golem3.py [--count 10000] [--scalar-count 10000]
        [--position-scalar-count 2000] [--output results.json]

Targets: FK of random joints inside the limits (seeded), as in the thesis' study. Per chain and
target kind it prints
- scalar ``solve``: solver time (IKResult.time_s: the method alone) median and p95, and the wall
  time per call (also target validation and the shared Pinocchio FK check);
- ``solve_many`` on the whole batch: the vectorised time per pose (IKResult.time_s) and wall time
  per pose including the per-target FK check;
- success rate, and the time to answer "no solution" for unreachable targets (FK pose moved 1 m).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import wbik

THESIS = {
    "pose": "thesis (custom analytic, 6-DOF): found 94 %, median 1.95 ms, 'no solution' in 1.7 ms",
    "position": "thesis (position-only sweep): found 100 %, mean 0.78 s, min 1.55 ms, max 6.75 s",
}


def targets(chain, kind: str, count: int, seed: int) -> list:
    joints = chain.random(np.random.default_rng(seed), count)
    poses = [chain.fk(q) for q in joints]
    return poses if kind == "pose" else [p.translation.copy() for p in poses]


def unreachable(chain, kind: str, count: int, seed: int) -> list:
    moved = []
    for target in targets(chain, kind, count, seed):
        if kind == "pose":
            moved.append(pin.SE3(target.rotation, target.translation + [1.0, 0.0, 0.0]))
        else:
            moved.append(target + [1.0, 0.0, 0.0])
    return moved


def scalar(solver, items: list) -> dict:
    solver_times, wall_times, found = [], [], 0
    for target in items:
        start = time.perf_counter()
        result = solver.solve(target)
        wall_times.append(time.perf_counter() - start)
        solver_times.append(result.time_s)
        found += result.success
    solver_times, wall_times = np.array(solver_times), np.array(wall_times)
    return {"count": len(items), "found": found / len(items),
            "solver_median_ms": 1e3 * float(np.median(solver_times)),
            "solver_p95_ms": 1e3 * float(np.percentile(solver_times, 95)),
            "solver_mean_ms": 1e3 * float(np.mean(solver_times)),
            "solver_max_ms": 1e3 * float(np.max(solver_times)),
            "wall_median_ms": 1e3 * float(np.median(wall_times)),
            "wall_p95_ms": 1e3 * float(np.percentile(wall_times, 95))}


def batch(solver, items: list) -> dict:
    start = time.perf_counter()
    results = solver.solve_many(items)
    wall = time.perf_counter() - start
    return {"count": len(items), "found": float(np.mean([r.success for r in results])),
            "vectorised_per_pose_us": 1e6 * results[0].time_s,
            "wall_per_pose_us": 1e6 * wall / len(items)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10_000, help="poses for solve_many")
    parser.add_argument("--scalar-count", type=int, default=10_000, help="poses for scalar solve (6-DOF)")
    parser.add_argument("--position-scalar-count", type=int, default=2_000,
                        help="positions for scalar solve (position-only)")
    parser.add_argument("--unreachable-count", type=int, default=500)
    parser.add_argument("--seed", type=int, default=2017)
    parser.add_argument("--chains", nargs="+", default=["right_arm", "left_arm"])
    parser.add_argument("--output", type=Path, help="JSON file, rewritten after every measurement")
    args = parser.parse_args()

    robot = wbik.load("golem3")
    report: dict = {}
    for chain_name in args.chains:
        solver = wbik.solver("analytic", robot, chain=chain_name)
        chain = solver.chain
        for kind in ("pose", "position"):
            scalar_count = args.scalar_count if kind == "pose" else args.position_scalar_count
            items = targets(chain, kind, max(args.count, scalar_count), args.seed)
            solver.solve(items[0])  # imports and caches out of the timing
            entry = {
                "scalar": scalar(solver, items[:scalar_count]),
                "batch": batch(solver, items[:args.count]),
                "unreachable_scalar": scalar(solver, unreachable(chain, kind, args.unreachable_count,
                                                                 args.seed + 1)),
            }
            report[f"{chain_name}/{kind}"] = entry
            if args.output:
                args.output.write_text(json.dumps(report, indent=2))
            s, b, u = entry["scalar"], entry["batch"], entry["unreachable_scalar"]
            print(f"\n{chain_name} / {kind}")
            print(f"  scalar solve ({s['count']}): found {100 * s['found']:.2f} %, solver time median "
                  f"{1e3 * s['solver_median_ms']:.1f} us, p95 {1e3 * s['solver_p95_ms']:.1f} us, mean "
                  f"{1e3 * s['solver_mean_ms']:.1f} us, max {1e3 * s['solver_max_ms']:.1f} us; wall per "
                  f"call median {1e3 * s['wall_median_ms']:.1f} us, p95 {1e3 * s['wall_p95_ms']:.1f} us")
            print(f"  solve_many ({b['count']}): found {100 * b['found']:.2f} %, vectorised "
                  f"{b['vectorised_per_pose_us']:.1f} us per pose, wall {b['wall_per_pose_us']:.1f} us "
                  "per pose (with the shared FK check)")
            print(f"  unreachable ({u['count']}, FK targets moved 1 m in x): found {100 * u['found']:.2f} %, "
                  f"'no solution' median {1e3 * u['solver_median_ms']:.1f} us, max "
                  f"{1e3 * u['solver_max_ms']:.1f} us")
            print(f"  {THESIS[kind]}")


if __name__ == "__main__":
    main()
