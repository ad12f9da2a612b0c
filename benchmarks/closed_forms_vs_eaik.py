"""Our closed forms against EAIK 1.2.2, in one process, on the same UR5 poses.

Targets: FK poses (Pinocchio) of --poses random joint vectors inside the UR5's limits (chain ``ee``,
base_link -> ee_link, seeded); every interface call starts from the chain's nominal configuration.
Rows, wall time per pose (each loop timed whole and divided by the poses; best of --repeats):

* EAIK raw: ``HPRobot.IK(pose)``, every branch, on poses already in EAIK's end-effector frame; no
  joint limits, no choice of a branch, no check. The reference of the ratios.
* EAIK raw batched: one ``IK_batched`` call with one worker thread.
* analytic solve / solve_all / solve_many: our UR5 closed form through ``wbik.solver("analytic")``,
  everything included (target conversion, wrapping into the limits, choice of the nearest branch, the
  shared Pinocchio FK check of each returned result).
* eaik solve / solve_all / solve_many: EAIK through ``wbik.solver("eaik")``, the same inclusions.

A last line times the Golem-III ``right_arm`` analytic ``solve`` (EAIK has no decomposition for it).

    .venv/bin/python benchmarks/closed_forms_vs_eaik.py
    .venv/bin/python benchmarks/closed_forms_vs_eaik.py --poses 500 --repeats 1
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import wbik


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=2000, help="UR5 poses (and Golem-III poses)")
    parser.add_argument("--repeats", type=int, default=3, help="each row is the best of this many loops")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the sampled joints")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.repeats < 1:
        parser.error("--poses and --repeats must be positive")
    return arguments


def best_per_pose(run, count: int, repeats: int) -> tuple[float, object]:
    """(best wall time per pose in seconds over ``repeats`` runs of ``run()``, the last run's output)."""
    best, output = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        output = run()
        best = min(best, (time.perf_counter() - start) / count)
    return best, output


def fk_poses(chain, count: int, seed: int) -> list:
    return [chain.fk(q) for q in chain.random(np.random.default_rng(seed), count)]


def main(argv: list[str] | None = None) -> None:
    arguments = parse_arguments(argv)
    count, repeats = arguments.poses, arguments.repeats
    ur5 = wbik.load("ur5")
    analytic = wbik.solver("analytic", ur5, "ee")
    eaik = wbik.solver("eaik", ur5, "ee")
    poses = fk_poses(analytic.chain, count, arguments.seed)
    eaik_poses = [eaik.eaik_pose(wbik.targets.as_target(pose)) for pose in poses]
    raw = eaik._thread_state()  # this thread's EAIK HPRobot, built from the chain's H and P
    for solver in (analytic, eaik):  # first-call costs out of the timings
        solver.solve(poses[0])
        solver.solve_all(poses[0])
        solver.solve_many(poses[:2])
    raw.IK(eaik_poses[0])

    rows = []  # (label, seconds per pose, successes or branches, note)
    seconds, out = best_per_pose(lambda: [raw.IK(pose) for pose in eaik_poses], count, repeats)
    rows.append(("EAIK raw IK (all branches)", seconds,
                 f"{np.mean([len(s.Q) for s in out]):.2f} branches/pose", "no limits, no choice, no check"))
    seconds, out = best_per_pose(lambda: raw.IK_batched(eaik_poses, num_worker_threads=1), count, repeats)
    rows.append(("EAIK raw IK_batched, 1 thread", seconds, f"{len(out)} answers", ""))
    for name, solver in (("analytic", analytic), ("eaik", eaik)):
        seconds, out = best_per_pose(lambda s=solver: [s.solve(pose) for pose in poses], count, repeats)
        rows.append((f"{name} solve", seconds, f"{sum(r.success for r in out)}/{count} solved",
                     "wall, everything included"))
        seconds, out = best_per_pose(lambda s=solver: [s.solve_all(pose) for pose in poses], count, repeats)
        rows.append((f"{name} solve_all", seconds, f"{np.mean([len(r) for r in out]):.2f} branches/pose",
                     "in limits, each FK-checked"))
        seconds, out = best_per_pose(lambda s=solver: s.solve_many(poses), count, repeats)
        rows.append((f"{name} solve_many", seconds, f"{sum(r.success for r in out)}/{count} solved",
                     "one call for all poses"))

    reference = rows[0][1]
    print(f"UR5 (example-robot-data) base_link -> ee_link, {count} FK poses of random joints, "
          f"best of {repeats} loops, wall time per pose")
    print(f"{'row':34s} {'us/pose':>9s} {'x EAIK raw':>10s}  {'outcome':24s} note")
    for label, seconds, outcome, note in rows:
        print(f"{label:34s} {seconds * 1e6:9.2f} {seconds / reference:10.2f}  {outcome:24s} {note}")

    golem = wbik.solver("analytic", wbik.load("golem3"), "right_arm")
    golem_poses = fk_poses(golem.chain, count, arguments.seed)
    golem.solve(golem_poses[0])
    seconds, out = best_per_pose(lambda: [golem.solve(pose) for pose in golem_poses], count, repeats)
    print(f"{'golem3 right_arm analytic solve':34s} {seconds * 1e6:9.2f} {seconds / reference:10.2f}  "
          f"{sum(r.success for r in out)}/{count} solved{'':10s} wall per call; EAIK refuses this chain")


if __name__ == "__main__":
    main()
