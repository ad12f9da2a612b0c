"""Pose of a chain's tip frame in its base frame for the given joint values."""

from __future__ import annotations

import argparse

import numpy as np

from wbik.commands.arguments import add_robot_arguments, load_robot_chain, print_json

HELP = "forward kinematics of a chain"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_robot_arguments(parser)
    parser.add_argument("--q", type=float, nargs="+", required=True, help="joint values, chain order")
    parser.add_argument("--deg", action="store_true", help="revolute joint values are in degrees")
    parser.add_argument("--json", action="store_true", help="print JSON")


def run(args: argparse.Namespace) -> int:
    import pinocchio as pin

    chain = load_robot_chain(args)[1]
    q = chain.check_q(args.q)
    if args.deg:
        q = np.where(chain.is_prismatic, q, np.radians(q))
    pose = chain.fk(q)
    rpy = pin.rpy.matrixToRpy(pose.rotation)
    out = {"robot": args.robot, "chain": chain.name, "base": chain.base_frame, "tip": chain.tip_frame,
           "q": q.tolist(), "position": pose.translation.tolist(), "rotation": pose.rotation.tolist(),
           "rpy": rpy.tolist(), "in_limits": chain.in_limits(q)}
    if args.json:
        return print_json(out)
    print(f"{chain.tip_frame} in {chain.base_frame} at q = {np.array2string(q, precision=6)}")
    print(f"  position (m): {np.array2string(pose.translation, precision=6)}")
    print(f"  rpy (rad):    {np.array2string(rpy, precision=6)}  (R = Rz(y) Ry(p) Rx(r))")
    print("  rotation:\n    " + np.array2string(pose.rotation, precision=6, prefix="    "))
    if not out["in_limits"]:
        print("  warning: q is outside the joint limits")
    return 0
