"""``wbik fk``: forward kinematics of a chain."""

from __future__ import annotations

import argparse
import json

import numpy as np


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "fk", help="forward kinematics of a chain",
        description="Pose of a chain's tip frame in its base frame for the given joint values.")
    parser.add_argument("robot", help="built-in robot name (see 'wbik robots') or a URDF path")
    parser.add_argument("--chain", help="chain name (default: the robot's only chain)")
    parser.add_argument("--q", type=float, nargs="+", required=True, help="joint values, chain order")
    parser.add_argument("--deg", action="store_true", help="revolute joint values are in degrees")
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import pinocchio as pin

    import wbik

    chain = wbik.load(args.robot).chain(args.chain)
    q = chain.check_q(args.q)
    if args.deg:
        q = np.where(chain.is_prismatic, q, np.radians(q))
    pose = chain.fk(q)
    rpy = pin.rpy.matrixToRpy(pose.rotation)
    out = {"robot": args.robot, "chain": chain.name, "base": chain.base_frame, "tip": chain.tip_frame,
           "q": q.tolist(), "position": pose.translation.tolist(), "rotation": pose.rotation.tolist(),
           "rpy": rpy.tolist(), "in_limits": chain.in_limits(q)}
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"{chain.tip_frame} in {chain.base_frame} at q = {np.array2string(q, precision=6)}")
    print(f"  position (m): {np.array2string(pose.translation, precision=6)}")
    print(f"  rpy (rad):    {np.array2string(rpy, precision=6)}  (R = Rz(y) Ry(p) Rx(r))")
    print("  rotation:\n" + np.array2string(pose.rotation, precision=6, prefix="    "))
    if not out["in_limits"]:
        print("  warning: q is outside the joint limits")
    return 0
