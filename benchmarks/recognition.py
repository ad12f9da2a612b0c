"""``analytic`` on chains without a hand binding: which closed form it recognises, how often it solves,
how long a solve takes.

Per arm: the family ``analytic`` finds from the chain's structure (or EAIK's decomposition, or a held
joint on a 7-joint arm), the time to build the solver (recognition and the model agreement check
included), and over --poses FK poses of random joints inside the limits (seeded): how many ``solve``
reaches within the shared tolerances and 1e-9 of FK error, and the median wall time of ``solve``
(``IKResult.time_s``, the method's time). Seed robots are loaded with their bindings removed. Starts:
the chain's nominal configuration; for 7-joint arms (the held joint searched, the default) also the
original joints (the start an arm tracking a path has), and the grid over the held joint.

    .venv/bin/python benchmarks/recognition.py [--poses 200]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
import pinocchio as pin

import wbik
from wbik.models.erd import urdf_path

FK_ERROR = 1e-9


def example(relative: str, chains=None) -> wbik.Robot:
    return wbik.load(str(urdf_path(relative)), **({"chains": chains} if chains else {}))


def ur(file: str) -> wbik.Robot:
    return example(f"ur_description/urdf/{file}")


def bare(name: str) -> wbik.Robot:
    return dataclasses.replace(wbik.load(name), closed_forms={})


def talos7() -> wbik.Robot:
    joints = tuple(f"arm_left_{i}_joint" for i in range(1, 8))
    spec = wbik.ChainSpec("left_arm", "torso_2_link", "gripper_left_base_link", joints)
    return wbik.load("erd:talos", chains=[spec])


def talos_arm6() -> wbik.Robot:
    joints = tuple(f"arm_left_{i}_joint" for i in range(2, 8))
    return example("talos_data/robots/talos_left_arm.urdf",
                   [wbik.ChainSpec("arm", "arm_left_1_link", "arm_left_7_link", joints)])


def kinova() -> wbik.Robot:
    joints = tuple(f"j2s6s200_joint_{i}" for i in range(1, 7))
    return wbik.load("erd:kinova", chains=[wbik.ChainSpec("arm", "base", "j2s6s200_end_effector", joints)])


ARMS = [  # (label, robot factory, chain, target kind, solver options, start)
    ("UR3 ur3_robot.urdf", lambda: ur("ur3_robot.urdf"), None, "pose", {}, "nominal"),
    ("UR3 joint-limited", lambda: ur("ur3_joint_limited_robot.urdf"), None, "pose", {},
     "nominal"),
    ("UR5 ur5_robot.urdf", lambda: ur("ur5_robot.urdf"), None, "pose", {}, "nominal"),
    ("UR10 ur10_robot.urdf", lambda: ur("ur10_robot.urdf"), None, "pose", {}, "nominal"),
    ("ur5.arm (tool), unbound", lambda: bare("ur5"), "arm", "pose", {}, "nominal"),
    ("pincher.arm, unbound", lambda: bare("pincher"), "arm", "pose", {}, "nominal"),
    ("pincher.arm, unbound", lambda: bare("pincher"), "arm", "position", {}, "nominal"),
    ("arm3r.arm, unbound", lambda: bare("arm3r"), "arm", "position", {}, "nominal"),
    ("arm3r.arm", lambda: wbik.load("arm3r"), "arm", "pose", {}, "nominal"),
    ("golem3.right_arm, unbound", lambda: bare("golem3"), "right_arm", "pose", {}, "nominal"),
    ("golem3.left_arm, unbound", lambda: bare("golem3"), "left_arm", "pose", {}, "nominal"),
    ("golem3.right_arm, unbound", lambda: bare("golem3"), "right_arm", "position", {}, "nominal"),
    ("bioloid.right_leg, unbound", lambda: bare("bioloid"), "right_leg", "pose", {}, "nominal"),
    ("talos_left_arm.urdf, 6R", talos_arm6, "arm", "pose", {}, "nominal"),
    ("kinova Jaco2 6R (continuous joints)", kinova, "arm", "pose", {}, "nominal"),
    ("panda.arm 7R", lambda: wbik.load("panda"), "arm", "pose", {}, "original"),
    ("panda.arm 7R", lambda: wbik.load("panda"), "arm", "pose", {}, "nominal"),
    ("panda.arm 7R grid", lambda: wbik.load("panda"), "arm", "pose", {"redundancy": "grid"}, "nominal"),
    ("panda.arm 7R joint 5", lambda: wbik.load("panda"), "arm", "pose", {"redundant_joint": "panda_joint5"},
     "original"),
    ("talos left arm 7R", talos7, "left_arm", "pose", {}, "original"),
    ("talos left arm 7R", talos7, "left_arm", "pose", {}, "nominal"),
    ("talos left arm 7R grid", talos7, "left_arm", "pose", {"redundancy": "grid"}, "nominal"),
    ("golem3.right_arm_lift P+6R", lambda: bare("golem3"), "right_arm_lift", "pose", {}, "original"),
    ("golem3.right_arm_lift grid", lambda: bare("golem3"), "right_arm_lift", "pose", {"redundancy": "grid"},
     "nominal"),
]


def fk_error(chain, q, target) -> float:
    reached = chain.fk(q)
    if isinstance(target, np.ndarray):
        return float(np.linalg.norm(reached.translation - target))
    return max(float(np.linalg.norm(reached.translation - target.translation)),
               float(np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))))


def measure(count: int) -> list[tuple[str, str, str, float, int, float]]:
    """Per arm: (label, kind, family, build time s, solved, median solve time s)."""
    rows = []
    for label, factory, chain_name, kind, options, start in ARMS:
        robot = factory()
        began = time.perf_counter()
        solver = wbik.solver("analytic", robot, chain_name, **options)
        built = time.perf_counter() - began
        chain = solver.chain
        solved, times = 0, []
        for q in chain.random(np.random.default_rng(0), count):
            pose = chain.fk(q)
            target = pose if kind == "pose" else pose.translation.copy()
            result = solver.solve(target, q0=q if start == "original" else None)
            solved += bool(result.success and fk_error(chain, result.q, target) < FK_ERROR)
            times.append(result.time_s)
        rows.append((f"{label} (start: {start})", kind, solver.families[kind], built, solved,
                     float(np.median(times))))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=200)
    arguments = parser.parse_args(argv)
    if arguments.poses < 1:
        parser.error("--poses must be positive")
    print(f"{'arm':48s} {'kind':8s} {'build':>8s} {'solved':>9s} {'median':>9s}  family")
    for label, kind, family, built, solved, median in measure(arguments.poses):
        print(f"{label:48s} {kind:8s} {built * 1e3:6.1f}ms {solved:4d}/{arguments.poses:<4d} "
              f"{median * 1e6:7.1f}us  {family}")


if __name__ == "__main__":
    main()
