"""Our closed forms against EAIK 1.2.2, in one process, on the same UR5 poses.

Targets: FK poses (Pinocchio) of --poses random joint vectors inside the UR5's limits (chain ``ee``,
base_link -> ee_link, seeded); every interface call starts from the chain's nominal configuration.
Rows, wall time per pose (each loop timed whole and divided by the poses). The rows are measured in
interleaved rounds (every row once per round, --rounds rounds) and each keeps its best round, so a
machine busy with other work distorts them less and alike:

* EAIK raw: ``HPRobot.IK(pose)``, every branch, on poses already in EAIK's end-effector frame; no
  joint limits, no choice of a branch, no check. The reference of the ratios.
* EAIK raw batched: one ``IK_batched`` call with one worker thread.
* analytic solve / solve_all / solve_many: our UR5 closed form through ``wbik.solver("analytic")``,
  everything included (target conversion, wrapping into the limits, choice of the nearest branch, the
  FK check of each returned result: Pinocchio's shared check in solve; the batched rule with the closed
  form's FK in solve_many, and in solve_all where the compiled kernel runs). The notes say whether the
  compiled UR kernel ran (``WBIK_PURE_PYTHON=1`` times its vectorised twin).
* analytic solve_many of an array: the same poses as one (B, 4, 4) array, the form EAIK's rows take them
  in (a 4 x 4 matrix each); the solve_many row above takes a list of ``pinocchio.SE3``.
* eaik solve / solve_all / solve_many: EAIK through ``wbik.solver("eaik")``, the same inclusions.

A last row times the Golem-III ``right_arm`` analytic ``solve`` (EAIK has no decomposition for it),
against wbik's fixed goal of 20 us per call.

    .venv/bin/python benchmarks/closed_forms_vs_eaik.py
    .venv/bin/python benchmarks/closed_forms_vs_eaik.py --poses 500 --rounds 3
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

import wbik
from wbik.kernels.twins import pure_python
from wbik.solvers.analytic import ur_type

ROUNDS = 9
"""Interleaved rounds (as benchmarks/qp.py). With 5, one run in a slow phase of this machine read the UR5
solve 45 % slower but EAIK's call only 17 % slower (13.6 and 6.1 us, against 9.4 and 5.2 us in the run
before): a phase can cover all five rounds of a row, and it does not slow Python and C alike."""
GOLEM_GOAL_S = 20e-6
"""The goal: Golem-III ``solve`` at most 20 us wall per call (a fixed bound, not a peer)."""


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", type=int, default=2000, help="UR5 poses (and Golem-III poses)")
    parser.add_argument("--rounds", type=int, default=ROUNDS, help="interleaved rounds; each keeps its best")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the sampled joints")
    arguments = parser.parse_args(argv)
    if arguments.poses < 1 or arguments.rounds < 1:
        parser.error("--poses and --rounds must be positive")
    return arguments


def fk_poses(chain, count: int, seed: int) -> list:
    return [chain.fk(q) for q in chain.random(np.random.default_rng(seed), count)]


def interleaved(rows: dict[str, tuple[Callable[[], object], int]],
                rounds: int) -> dict[str, tuple[float, object]]:
    """Each row's best wall time per item over ``rounds`` interleaved rounds (``best_of_rounds``):
    {label: (seconds per item, the last run's output)} for rows {label: (run, items)}."""
    from ratios import best_of_rounds

    outputs: dict[str, object] = {}

    def timed(label: str, run: Callable[[], object], items: int) -> Callable[[], float]:
        def seconds_per_item() -> float:
            start = time.perf_counter()
            outputs[label] = run()
            return (time.perf_counter() - start) / items
        return seconds_per_item

    best = best_of_rounds({label: timed(label, run, items) for label, (run, items) in rows.items()}, rounds)
    return {label: (best[label], outputs[label]) for label in rows}


def measure(count: int, rounds: int, seed: int) -> tuple[dict[str, tuple[float, str, str]], int]:
    """{label: (seconds per pose, outcome, note)} for every row, and the number of Golem-III poses."""
    ur5 = wbik.load("ur5")
    analytic = wbik.solver("analytic", ur5, "ee")
    eaik = wbik.solver("eaik", ur5, "ee")
    poses = fk_poses(analytic.chain, count, seed)
    eaik_poses = [eaik.eaik_pose(wbik.targets.as_target(pose)) for pose in poses]
    from eaik.IK_HP import HPRobot

    raw = HPRobot(eaik.structure.H, eaik.structure.P)  # EAIK's own robot of the chain's H and P
    golem = wbik.solver("analytic", wbik.load("golem3"), "right_arm")
    golem_poses = fk_poses(golem.chain, count, seed)
    for solver, first in ((analytic, poses[0]), (eaik, poses[0]), (golem, golem_poses[0])):
        solver.solve(first)  # first-call costs (imports, thread state) out of the timings
        solver.solve_all(first)
        solver.solve_many([first, first])
    raw.IK(eaik_poses[0])
    rows = {
        "EAIK raw IK (all branches)": (lambda: [raw.IK(pose) for pose in eaik_poses], count),
        "EAIK raw IK_batched, 1 thread": (lambda: raw.IK_batched(eaik_poses, num_worker_threads=1), count),
    }
    for name, solver in (("analytic", analytic), ("eaik", eaik)):
        rows[f"{name} solve"] = (lambda s=solver: [s.solve(pose) for pose in poses], count)
        rows[f"{name} solve_all"] = (lambda s=solver: [s.solve_all(pose) for pose in poses], count)
        rows[f"{name} solve_many"] = (lambda s=solver: s.solve_many(poses), count)
    matrices = np.array([pose.homogeneous for pose in poses])  # the poses as EAIK takes them: 4 x 4 arrays
    rows["analytic solve_many of an array"] = (lambda: analytic.solve_many(matrices), count)
    rows["golem3 right_arm analytic solve"] = (lambda: [golem.solve(pose) for pose in golem_poses], count)
    timed = interleaved(rows, rounds)
    results = {}
    for label, (seconds, out) in timed.items():
        if label.startswith("EAIK raw IK ("):
            outcome = f"{np.mean([len(s.Q) for s in out]):.2f} branches/pose"
            note = "no limits, no choice, no check"
        elif label.startswith("EAIK raw"):
            outcome, note = f"{len(out)} answers", ""
        elif label.endswith("solve_all"):
            outcome = f"{np.mean([len(r) for r in out]):.2f} branches/pose"
            note = "in limits, each FK-checked"
        else:
            outcome = f"{sum(r.success for r in out)}/{count} solved"
            note = "one call for all poses" if "solve_many" in label else "wall, everything included"
        results[label] = (seconds, outcome, note)
    return results, count


def ratios(quick: bool = False) -> list:
    """The closed-form goals as ratios: UR5 ``solve`` / ``solve_all`` / ``solve_many`` against EAIK's raw
    all-branch time per pose in the same run, and Golem-III ``solve`` against the fixed 20 us goal."""
    from ratios import Ratio

    count, rounds = (300, 3) if quick else (2000, ROUNDS)
    rows, _ = measure(count, rounds, seed=0)
    peer = rows["EAIK raw IK (all branches)"][0]
    path = ("UR closed form: compiled kernel (wbik/kernels/_ur_type.c)"
            if ur_type._ur_kernel is not None and not pure_python("ur_type")
            else "UR closed form: its vectorised twin (kernel not built or WBIK_PURE_PYTHON)")
    how = (f"UR5 ee, {count} FK poses from the nominal start, best of {rounds} interleaved rounds; "
           f"ours wall time with everything (conversion, limits, choice, FK check); EAIK raw: "
           f"HPRobot.IK on every pose, all branches, no limits, no choice, no check; {path}")
    return [
        Ratio("UR5 closed-form solve <= 1.5x EAIK all branches", "analytic solve (UR5)",
              rows["analytic solve"][0], "EAIK raw IK (all branches)", peer, "s/pose", 1.5,
              note=f"{how}; {rows['analytic solve'][1]}"),
        Ratio("UR5 closed-form solve_all <= 3x EAIK all branches", "analytic solve_all (UR5)",
              rows["analytic solve_all"][0], "EAIK raw IK (all branches)", peer, "s/pose", 3.0,
              note=f"{how}; {rows['analytic solve_all'][1]}, each an IKResult, checked with the closed "
                   f"form's FK as in solve_many where the kernel runs (solve: Pinocchio's)"),
        Ratio("UR5 closed-form solve_many per pose <= 0.5x EAIK per call", "analytic solve_many (UR5)",
              rows["analytic solve_many of an array"][0], "EAIK raw IK (all branches)", peer, "s/pose", 0.5,
              note=f"{how}; one solve_many call for all poses, given as EAIK takes them, 4 x 4 matrices "
                   f"(one (B, 4, 4) array), {rows['analytic solve_many of an array'][1]}"),
        Ratio("UR5 closed-form solve_many per pose, a list of SE3", "analytic solve_many (UR5, SE3s)",
              rows["analytic solve_many"][0], "EAIK raw IK (all branches)", peer, "s/pose",
              note=f"{how}; one solve_many call for a list of pinocchio.SE3 (each read as a matrix, about "
                   f"0.3 us), {rows['analytic solve_many'][1]}"),
        Ratio("Golem-III closed-form solve <= 20 us", "analytic solve (Golem-III right_arm)",
              rows["golem3 right_arm analytic solve"][0], "goal 20 us", GOLEM_GOAL_S, "s/call", 1.0,
              note=(f"a ratio to the fixed bound, not to a peer (EAIK refuses the chain); {count} FK "
                    f"poses, best of {rounds} interleaved rounds, wall per call; "
                    f"{rows['golem3 right_arm analytic solve'][1]}")),
    ]


def main(argv: list[str] | None = None) -> None:
    arguments = parse_arguments(argv)
    rows, count = measure(arguments.poses, arguments.rounds, arguments.seed)
    reference = rows["EAIK raw IK (all branches)"][0]
    print(f"UR5 (example-robot-data) base_link -> ee_link, {count} FK poses of random joints, best of "
          f"{arguments.rounds} interleaved rounds, wall time per pose")
    print(f"{'row':34s} {'us/pose':>9s} {'x EAIK raw':>10s}  {'outcome':24s} note")
    for label, (seconds, outcome, note) in rows.items():
        if label.startswith("golem3"):
            note = "wall per call; EAIK refuses this chain; goal 20 us"
        print(f"{label:34s} {seconds * 1e6:9.2f} {seconds / reference:10.2f}  {outcome:24s} {note}")


if __name__ == "__main__":
    main()
