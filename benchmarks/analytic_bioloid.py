"""Benchmark of the Bioloid closed forms: per chain, scalar and batched solve times and success rates.

Targets are Pinocchio FK of seeded random joints inside the limits, drawn where the thesis's
closed forms are meant to work: legs with the knee on the walking branch (flexion >= 2 alpha),
and for the leg position form (hip -> foot, foot parallel to the hip) with the foot parallel to
the hip; arms anywhere inside the limits. Every solve starts from the chain's nominal.

Columns: ``solve`` wall time per pose (median, 95th percentile, over --scalar-poses targets),
``solve_many`` wall time per pose on --poses targets (the whole call, including the shared FK check
of every result), the closed-form part of it, success rates, and the bare thesis functions
(``leg_foot_to_hip`` / ``arm_ik`` on a numpy batch) per pose.

    .venv/bin/python benchmarks/analytic_bioloid.py                      # 10,000 poses per chain
    .venv/bin/python benchmarks/analytic_bioloid.py --poses 2000 --output bioloid.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import wbik
from wbik.robot_packages.bioloid import closed_form as closed

sys.path.insert(0, str(Path(__file__).resolve().parent))
from analytic import time_solver  # noqa: E402  (the shared timing loop of benchmarks/analytic.py)

ALPHA = math.atan2(0.0145, 0.075)
CASES = [("right_leg", "pose"), ("left_leg", "pose"), ("right_leg", "position"), ("left_leg", "position"),
         ("right_arm", "position"), ("left_arm", "position")]


def parse_arguments(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=10_000, help="targets per chain for solve_many")
    parser.add_argument("--scalar-poses", type=int, default=1000, help="targets timed one by one with solve")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=Path, default=None, help="append one JSON line per chain here")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.scalar_poses < 1:
        parser.error("--poses and --scalar-poses must be positive")
    return arguments


def sample_joints(chain, kind: str, count: int, rng: np.random.Generator) -> np.ndarray:
    """Random joints inside the limits where the thesis's closed form applies (see the docstring)."""
    if "arm" in chain.name:
        return chain.random(rng, count)
    rows = []
    while sum(len(r) for r in rows) < count:
        q = chain.random(rng, 4 * count)
        q[:, 3] = rng.uniform(2 * ALPHA, chain.upper[3], len(q))
        if kind == "position":
            q[:, 0], q[:, 1], q[:, 2] = 0.0, -q[:, 5], -(q[:, 3] + q[:, 4])
            q = q[np.all((q >= chain.lower) & (q <= chain.upper), axis=1)]
        rows.append(q)
    return np.concatenate(rows)[:count]


def bare_thesis_time(chain, kind: str, joints: np.ndarray) -> float:
    """Seconds per pose of the vectorised thesis function alone (no limits, no FK check)."""
    poses = [chain.fk(q) for q in joints]
    if "arm" in chain.name:
        points = np.array([pose.translation for pose in poses])
        start = time.perf_counter()
        closed.arm_ik(points, chain.name.split("_")[0])
    else:
        hips = [pose.inverse() for pose in poses]
        points = np.array([hip.translation for hip in hips])
        start = time.perf_counter()
        closed.leg_foot_to_hip(points, 0.0, 0.0, 0.0, chain.name.split("_")[0])
    return (time.perf_counter() - start) / len(joints)


def measure(robot, chain_name: str, kind: str, poses: int, scalar_poses: int, seed: int) -> dict:
    solver = wbik.solver("analytic", robot, chain=chain_name)
    chain = solver.chain
    joints = sample_joints(chain, kind, poses, np.random.default_rng(seed))
    fk = [chain.fk(q) for q in joints]
    targets = fk if kind == "pose" else [pose.translation.copy() for pose in fk]
    return {"chain": chain_name, "kind": kind, "poses": poses,
            **time_solver(solver, targets, scalar_poses),
            "thesis_function_us_per_pose": bare_thesis_time(chain, kind, joints[:poses]) * 1e6}


def main(argv=None) -> None:
    arguments = parse_arguments(argv)
    robot = wbik.load("bioloid")
    header = (f"{'chain':10s} {'kind':8s} {'solve med':>10s} {'p95':>8s} {'ok %':>7s} | "
              f"{'many/pose':>10s} {'cf/pose':>8s} {'ok %':>8s} | {'thesis fn':>9s}  (microseconds)")
    print(header)
    for chain_name, kind in CASES:
        row = measure(robot, chain_name, kind, arguments.poses, min(arguments.scalar_poses, arguments.poses),
                      arguments.seed)
        print(f"{row['chain']:10s} {row['kind']:8s} {row['scalar_median_us']:10.1f} "
              f"{row['scalar_p95_us']:8.1f} {row['scalar_success_pct']:7.2f} | "
              f"{row['batch_us_per_pose']:10.2f} "
              f"{row['closed_form_us_per_pose']:8.2f} {row['batch_success_pct']:8.3f} | "
              f"{row['thesis_function_us_per_pose']:9.3f}", flush=True)
        if arguments.output is not None:
            with arguments.output.open("a") as stream:
                stream.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
