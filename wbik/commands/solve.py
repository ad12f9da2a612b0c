"""Solve IK for a position (--xyz) or a pose (--xyz and --rpy) of a chain's tip in its base frame. Prints
the joints, the errors (shared FK check) and the time."""

from __future__ import annotations

import argparse

import numpy as np

from wbik.commands.arguments import add_robot_arguments, load_robot_chain, print_json

HELP = "solve IK for one target"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_robot_arguments(parser)
    parser.add_argument("--method", default="dls", help="IK method (see 'wbik methods'); default dls")
    parser.add_argument("--xyz", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"),
                        help="target position (m)")
    parser.add_argument("--rpy", type=float, nargs=3, metavar=("R", "P", "Y"),
                        help="target orientation, R = Rz(Y) Ry(P) Rx(R) (rad); omit for position only")
    parser.add_argument("--q0", type=float, nargs="+", help="start / current joints (default: nominal)")
    parser.add_argument("--timeout", type=float, default=0.05, help="time budget in s (default 0.05)")
    parser.add_argument("--all", action="store_true", help="every solution (closed-form methods)")
    parser.add_argument("--json", action="store_true", help="print JSON")


def run(args: argparse.Namespace) -> int:
    import pinocchio as pin

    from wbik.options import TIMEOUT_S
    from wbik.scenarios.wholebody import split_diagnosis
    from wbik.solvers.method_registry import solver as make_solver
    from wbik.targets import Target

    timeout = TIMEOUT_S.checked(args.timeout, "--timeout", "wbik solve")
    robot, chain = load_robot_chain(args)
    solver = make_solver(args.method, robot, chain=chain.name, timeout_s=timeout)
    position = np.array(args.xyz)
    target = pin.SE3(pin.rpy.rpyToMatrix(*args.rpy), position) if args.rpy is not None else Target(position)
    results = solver.solve_all(target) if args.all else [solver.solve(target, args.q0)]
    family = solver_family(solver, "position" if args.rpy is None else "pose")
    if args.json:
        payload = [dict(r.as_dict(), **({"family": family} if family else {})) for r in results]
        print_json(payload if args.all else payload[0])
    else:
        if not results:
            print("no solution")
        for result in results:  # the diagnosis's summary printed below it, line by line
            reason, diagnosis = split_diagnosis(result.reason, result.as_dict().get("diagnosis"))
            status = "solved" if result.success else f"NOT solved: {reason}"
            solved_by = f" (closed form: {family})" if family else ""
            print(f"{result.method} on {robot.name}.{solver.chain.name}{solved_by}: {status}")
            if result.q is not None:
                for name, value in zip(solver.chain.joint_names, result.q, strict=True):
                    print(f"  {name:24s} {value: .9f}")
            print(f"  position error {result.position_error:.3e} m, rotation error "
                  f"{result.rotation_error:.3e} rad, {result.iterations} iterations, "
                  f"{result.time_s * 1e3:.3f} ms")
            for line in diagnosis:
                print(f"  {line}")
    return 0 if results and all(r.success for r in results) else 1  # 1: ran, but not solved


def solver_family(solver, kind: str) -> str | None:
    """The closed form solving the chain (``analytic``'s family for this target kind, ``eaik``'s class)."""
    families = getattr(solver, "families", None)
    if isinstance(families, dict):
        return families.get(kind)
    family = getattr(solver, "family", None)
    return family if isinstance(family, str) else None

