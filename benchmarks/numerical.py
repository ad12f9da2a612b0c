"""Numerical IK benchmark, TRAC-IK's published protocol, for every numerical method on every chain.

Protocol (Beeson & Ames, TRAC-IK, 2015): random reachable poses (FK of uniform random joints inside
the limits), full 6-D pose, tolerance 1e-5 (here: the shared FK check, position norm <= 1e-5 m and
rotation angle <= 1e-5 rad), every solve seeded from the mid-range configuration, 5 ms budget.
Per method and chain it prints the success rate and mean / median / p95 time per call, and our
solver's (bounded_lm's) mean time as a ratio to TRAC-IK's in the same run.

The Pincher has 4 joints, so a pose it can reach is fixed by its position and the tool pitch
(the other orientation components follow); its targets are the full FK poses of random joints,
i.e. position + pitch targets written as poses, which every method takes.

    .venv/bin/python benchmarks/numerical.py --poses 2000
    .venv/bin/python benchmarks/numerical.py --chains ur5:arm panda:arm --methods trac_ik bounded_lm

Rows are appended to ``--output`` (JSON lines) as each (chain, method) finishes, so an
interrupted run keeps what it measured.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import wbik
from wbik.errors import WbikError
from wbik.solvers.base import Tolerances

DEFAULT_CHAINS = ["ur5:arm", "golem3:right_arm", "pincher:arm", "bioloid:right_leg", "panda:arm"]
DEFAULT_METHODS = ["newton", "dls", "kdl", "kdl_restarts", "trac_ik", "bounded_lm"]


def poses_for(chain: wbik.Chain, count: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    return [chain.fk(q) for q in chain.random(rng, count)]


def measure(method: str, robot, chain_name: str, poses: list, timeout_s: float, tolerance: float,
            options: dict) -> dict:
    solver = wbik.solver(method, robot, chain=chain_name, timeout_s=timeout_s,
                         tolerances=Tolerances(tolerance, tolerance), **options)
    chain = solver.chain
    seed = chain.mid_range
    times, successes, outside = [], 0, 0
    for pose in poses:
        result = solver.solve(pose, seed)
        times.append(result.time_s)
        successes += result.success
        if result.q is not None and not chain.in_limits(result.q):
            outside += 1
    times_ms = np.array(times) * 1e3
    return {"method": method, "poses": len(poses), "success": successes / len(poses),
            "mean_ms": float(times_ms.mean()), "median_ms": float(np.median(times_ms)),
            "p95_ms": float(np.percentile(times_ms, 95)), "outside_limits": outside}


def parse_options(pairs: list[str]) -> dict:
    options = {}
    for pair in pairs:
        key, _, value = pair.partition("=")
        try:
            options[key] = json.loads(value)
        except json.JSONDecodeError:
            options[key] = value
    return options


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=10000, help="random poses per chain (protocol: 10000)")
    parser.add_argument("--chains", nargs="+", default=DEFAULT_CHAINS, help="robot:chain names")
    parser.add_argument("--methods", nargs="+", default=DEFAULT_METHODS)
    parser.add_argument("--timeout-ms", type=float, default=5.0, help="time budget per call (ms)")
    parser.add_argument("--tolerance", type=float, default=1e-5, help="m and rad (protocol: 1e-5)")
    parser.add_argument("--seed", type=int, default=2015, help="seed of the random poses")
    parser.add_argument("--option", nargs="*", default=[], metavar="METHOD.KEY=VALUE",
                        help="solver options, e.g. bounded_lm.batch_size=8")
    parser.add_argument("--output", type=Path, default=Path("runs/numerical.jsonl"))
    args = parser.parse_args(argv)
    per_method: dict[str, dict] = {}
    for item in parse_options(args.option).items():
        method, _, key = item[0].partition(".")
        per_method.setdefault(method, {})[key] = item[1]
    args.output.parent.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y-%m-%dT%H:%M:%S")
    for spec in args.chains:
        robot_name, _, chain_name = spec.partition(":")
        try:
            robot = wbik.load(robot_name)
            chain = robot.chain(chain_name or None)
        except (WbikError, ImportError) as exc:
            print(f"\n{spec}: skipped ({exc})")
            continue
        poses = poses_for(chain, args.poses, args.seed)
        print(f"\n{spec}: {chain.nq} joints, {len(poses)} poses, budget {args.timeout_ms:g} ms, "
              f"tolerance {args.tolerance:g}, seed = mid-range")
        print(f"{'method':<14}{'success %':>10}{'mean ms':>10}{'median ms':>11}{'p95 ms':>9}")
        rows = {}
        for method in args.methods:
            try:
                row = measure(method, robot, chain.name, poses, args.timeout_ms / 1e3, args.tolerance,
                              per_method.get(method, {}))
            except (WbikError, ImportError) as exc:
                print(f"{method:<14}  unavailable: {exc}")
                continue
            rows[method] = row
            print(f"{method:<14}{100 * row['success']:>10.2f}{row['mean_ms']:>10.3f}"
                  f"{row['median_ms']:>11.3f}{row['p95_ms']:>9.3f}"
                  + (f"   ({row['outside_limits']} outside limits!)" if row["outside_limits"] else ""))
            with args.output.open("a") as stream:
                stream.write(json.dumps({"run": stamp, "chain": spec, "timeout_ms": args.timeout_ms,
                                         "tolerance": args.tolerance, **row}) + "\n")
            sys.stdout.flush()
        if "bounded_lm" in rows and "trac_ik" in rows:
            ours, theirs = rows["bounded_lm"], rows["trac_ik"]
            print(f"bounded_lm / trac_ik: mean time x{ours['mean_ms'] / theirs['mean_ms']:.2f}, "
                  f"success {100 * ours['success']:.2f} % vs {100 * theirs['success']:.2f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
