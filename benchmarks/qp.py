"""Whole-body QP IK on the Bioloid (nv = 24): our QP per backend vs Pink (pin-pink) vs PlaCo.

Same tasks for all, same run: the robot stands on the right foot (its CoM first moved over it),
the right sole is a hard contact, the left sole has a frame task 40 mm up, the pelvis keeps its
orientation (soft, weight 0.1), small regularisation, joint limits. Ours and PlaCo also hold the
CoM inside the right sole shrunk by 5 mm (hard); Pink has no support-polygon constraint, so it
runs without it (it is inactive at this configuration anyway: the CoM stays > 10 mm inside).

Printed: time per QP step (kinematics update + QP build + solve, at the start configuration) and
per converged IK (to 1e-6 on the foot task), with ratios to PlaCo and to Pink, the final CoM margin
in the right sole by FK against wbik's SupportPolygon, and Pink's and PlaCo's settings. PlaCo gets
its CoM polygon clockwise, as its CoMPolygonConstraint wants, and configured hard (its default
priority is soft); ``placo_problem`` builds that problem (tests/test_peer_configuration.py too).

Then where our step's time goes: a table of the phases of ``IKProblem.step`` (kinematics,
constraint rows, task rows, H and c, the DAQP call; its ``profile`` argument) per step and per
converged IK, where the IK adds the contact projections and the rest of the loop (merit, checks,
integration, report). ``cProfile`` on ``problem.step`` / ``problem.solve`` gives the same picture
by function.

Run: .venv/bin/python benchmarks/qp.py [--repeats 300]
"""

from __future__ import annotations

import argparse
import time
from types import SimpleNamespace

import numpy as np
import pinocchio as pin

import wbik
from wbik.qp import ComTask, FrameTask, IKProblem, OrientationTask, RegularizationTask, available_backends
from wbik.qp.humanoid import stance_constraints, support_polygon
from wbik.qp.problem import PHASES

MARGIN = 0.005
LIFT = np.array([0.0, 0.0, 0.04])


def stand_on_right_foot(robot) -> np.ndarray:
    """The CoM over the right sole, both soles fixed (the first phase of tasks/bioloid_balance.yaml)."""
    q0 = robot.nominal
    right = robot.frame_placement(q0, "r_sole").translation
    problem = IKProblem(robot.model, [ComTask([right[0], right[1], 0.0], axes="xy"),
                                      OrientationTask("pelvis", robot.frame_placement(q0, "pelvis").rotation,
                                                      weight=0.1, goal=False), RegularizationTask(1e-6)],
                        stance_constraints(robot, q0, ["r_sole", "l_sole"], margin=MARGIN), backend="daqp")
    solution = problem.solve(q0)
    assert solution.success, solution.reason
    return solution.q


def best_of(function, repeats: int) -> float:
    """Median time of one call (s) over ``repeats`` calls."""
    times = np.empty(repeats)
    for i in range(repeats):
        start = time.perf_counter()
        function()
        times[i] = time.perf_counter() - start
    return float(np.median(times))


def our_problem(robot, q_start, foot_target, backend="daqp") -> IKProblem:
    pelvis = robot.frame_placement(q_start, "pelvis").rotation
    return IKProblem(robot.model, [FrameTask("l_sole", foot_target),
                                   OrientationTask("pelvis", pelvis, weight=0.1, goal=False),
                                   RegularizationTask(1e-6)],
                     stance_constraints(robot, q_start, ["r_sole"], margin=MARGIN), backend=backend)


def ours(robot, q_start, foot_target, backend, repeats):
    problem = our_problem(robot, q_start, foot_target, backend)
    problem.start(q_start)

    def one_step():
        problem.step(q_start, dt=1.0)

    step = best_of(one_step, repeats)
    solution = problem.solve(q_start)
    ik = best_of(lambda: problem.solve(q_start), max(repeats // 10, 5))
    return (step, ik, solution.iterations, solution.success, foot_error(robot, solution.q, foot_target),
            com_margin_by_fk(robot, solution.q, support_polygon(robot, q_start, ["r_sole"])))


def phase_table(robot, q_start, foot_target, repeats: int) -> None:
    """Where the time goes (DAQP): one QP step by phase (IKProblem.step's ``profile``), and one
    converged IK split into its QP steps (by phase), the contact projections and the rest (merit,
    task errors, FK checks, integration, the final report)."""
    problem = our_problem(robot, q_start, foot_target)
    problem.start(q_start)
    steps = {}
    for _ in range(repeats):
        problem.step(q_start, dt=1.0, profile=steps)
    solve_steps, other = {}, {"projection": 0.0}
    step, project = problem.step, problem.project

    def timed_step(*args, **kwargs):
        return step(*args, profile=solve_steps, **kwargs)

    def timed_project(*args, **kwargs):
        start = time.perf_counter()
        result = project(*args, **kwargs)
        other["projection"] += time.perf_counter() - start
        return result

    problem.step, problem.project = timed_step, timed_project
    solves = max(repeats // 10, 5)
    total = 0.0
    for _ in range(solves):
        start = time.perf_counter()
        solution = problem.solve(q_start)
        total += time.perf_counter() - start
    del problem.step, problem.project
    other["checks, merit, rest"] = total - sum(solve_steps.values()) - other["projection"]
    print(f"Where the time goes (wbik.qp [daqp], us; mean of {repeats} steps and {solves} IK solves of "
          f"{solution.iterations} iterations):")
    print(f"{'phase':22s} {'per step':>9s} {'share':>6s} {'per IK':>9s} {'share':>6s}")
    step_total = sum(steps.values())
    for phase in (*PHASES, "projection", "checks, merit, rest"):
        per_step = steps.get(phase, 0.0) / repeats
        per_ik = (solve_steps.get(phase, 0.0) + other.get(phase, 0.0)) / solves
        print(f"{phase:22s} {per_step * 1e6:9.1f} {per_step / (step_total / repeats):6.0%} "
              f"{per_ik * 1e6:9.1f} {per_ik / (total / solves):6.0%}")
    print(f"{'total':22s} {step_total / repeats * 1e6:9.1f} {'':6s} {total / solves * 1e6:9.1f}")


def foot_error(robot, q, target) -> float:
    reached = robot.frame_placement(q, "l_sole")
    return float(max(np.linalg.norm(reached.translation - target.translation),
                     np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))))


def pink_run(robot, q_start, foot_target, repeats, solver="daqp"):
    import pink
    from pink.limits import ConfigurationLimit
    from pink.tasks import FrameTask as PinkFrameTask

    model = robot.model
    data = model.createData()
    right = PinkFrameTask("r_sole", position_cost=1.0, orientation_cost=1.0)
    left = PinkFrameTask("l_sole", position_cost=1.0, orientation_cost=1.0)
    pelvis = PinkFrameTask("pelvis", position_cost=0.0, orientation_cost=np.sqrt(0.1))
    configuration = pink.Configuration(model, data, q_start)
    right.set_target_from_configuration(configuration)
    pelvis.set_target_from_configuration(configuration)
    left.set_target(foot_target)
    limits = [ConfigurationLimit(model)]

    def one_step(configuration=configuration):
        configuration.update(q_start)
        pink.solve_ik(configuration, [left, pelvis], 1.0, solver=solver, damping=1e-6,
                      constraints=[right], limits=limits, safety_break=False)

    step = best_of(one_step, repeats)

    def converge():
        q = q_start.copy()
        config = pink.Configuration(model, data, q)
        for iteration in range(1, 201):
            v = pink.solve_ik(config, [left, pelvis], 1.0, solver=solver, damping=1e-6,
                              constraints=[right], limits=limits, safety_break=False)
            q = pin.integrate(model, config.q, v)
            config.update(q)
            if foot_error(robot, q, foot_target) <= 1e-6:
                return q, iteration
        return q, 200

    q_final, iterations = converge()
    ik = best_of(converge, max(repeats // 10, 5))
    return (step, ik, iterations, foot_error(robot, q_final, foot_target) <= 1e-6,
            foot_error(robot, q_final, foot_target),
            com_margin_by_fk(robot, q_final, support_polygon(robot, q_start, ["r_sole"])))


def signed_area(vertices) -> float:
    """Shoelace area of a polygon: positive counter-clockwise, negative clockwise."""
    v = np.asarray(vertices, dtype=float)
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def placo_polygon(polygon, clockwise: bool = True) -> list[np.ndarray]:
    """The support polygon's vertices as PlaCo's CoMPolygonConstraint wants them: clockwise.

    PlaCo (com_polygon_constraint.h, polygon_constraint.h) takes a *clockwise* polygon: its edge
    normal (dy, -dx) points inside only then. ``clockwise=False`` gives the counter-clockwise order
    (what the benchmark handed PlaCo before), which inverts every half-plane.
    """
    vertices = [np.array(v, dtype=float) for v in polygon.vertices]
    if (signed_area(vertices) < 0) != clockwise:
        vertices = vertices[::-1]
    return vertices


PLACO_SETTINGS = ("PlaCo: KinematicsSolver, joint limits on; r_sole frame task hard; l_sole frame task soft "
                  "(w 1); pelvis orientation soft (w 0.1); CoM polygon = right sole shrunk 5 mm, "
                  "clockwise (PlaCo's convention), configured hard; regularisation 1e-6; solve(True) "
                  "per iteration.")
PINK_SETTINGS = ("Pink: solve_ik, dt 1, damping 1e-6, r_sole FrameTask as an equality constraint, l_sole "
                 "FrameTask (costs 1, 1), pelvis FrameTask (position 0, orientation sqrt 0.1), "
                 "ConfigurationLimit; no CoM polygon (Pink has none).")


def placo_problem(robot, q_start, foot_target, clockwise: bool = True, hard: bool = True) -> SimpleNamespace:
    """The PlaCo problem this benchmark solves (also built by tests/test_peer_configuration.py).

    Returns wrapper, solver, the tasks, the CoM polygon constraint ``com``, the wbik
    SupportPolygon ``polygon`` of the right sole and the vertices handed to PlaCo. The CoM
    constraint is made hard with ``configure(name, "hard")`` (PlaCo's default priority is soft).
    """
    import placo

    from wbik.solvers.placo import placo_robot

    wrapper = placo_robot(robot, q_start)
    solver = placo.KinematicsSolver(wrapper)
    solver.enable_joint_limits(True)
    right = solver.add_frame_task("r_sole", robot.frame_placement(q_start, "r_sole").homogeneous)
    right.configure("r_sole", "hard", 1.0)
    left = solver.add_frame_task("l_sole", foot_target.homogeneous)
    left.configure("l_sole", "soft", 1.0)
    pelvis = solver.add_orientation_task("pelvis", robot.frame_placement(q_start, "pelvis").rotation)
    pelvis.configure("pelvis", "soft", 0.1)
    polygon = support_polygon(robot, q_start, ["r_sole"])
    vertices = placo_polygon(polygon, clockwise)
    com = solver.add_com_polygon_constraint(vertices, MARGIN)
    com.configure("com_polygon", "hard" if hard else "soft", 1.0)
    solver.add_regularization_task(1e-6)
    return SimpleNamespace(wrapper=wrapper, solver=solver, right=right, left=left, pelvis=pelvis, com=com,
                           polygon=polygon, vertices=vertices)


def com_margin_by_fk(robot, q, polygon) -> float:
    """CoM ground projection's distance inside our SupportPolygon (m, negative outside), by FK."""
    return float(polygon.margin_of(robot.center_of_mass(q)[:2]))


def placo_run(robot, q_start, foot_target, repeats):
    from wbik.solvers.placo import placo_configuration, set_placo_configuration

    setup = placo_problem(robot, q_start, foot_target)
    wrapper, solver, left = setup.wrapper, setup.solver, setup.left

    def one_step():
        set_placo_configuration(robot, wrapper, q_start)
        solver.solve(False)

    # the configuration copy (by joint name, from Python) is not PlaCo's cost: time it apart
    copy_only = best_of(lambda: set_placo_configuration(robot, wrapper, q_start), repeats)
    step = best_of(one_step, repeats) - copy_only

    def converge():
        set_placo_configuration(robot, wrapper, q_start)
        for iteration in range(1, 201):
            solver.solve(True)
            wrapper.update_kinematics()
            if np.linalg.norm(left.position().error()) <= 1e-6 and np.linalg.norm(
                    left.orientation().error()) <= 1e-6:
                return iteration
        return 200

    iterations = converge()
    q_final = placo_configuration(robot, wrapper)
    ik = best_of(converge, max(repeats // 10, 5)) - copy_only
    error = foot_error(robot, q_final, foot_target)
    return step, ik, iterations, error <= 1e-6, error, com_margin_by_fk(robot, q_final, setup.polygon)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300)
    args = parser.parse_args()
    robot = wbik.load("bioloid")
    q_start = stand_on_right_foot(robot)
    foot_target = robot.frame_placement(q_start, "l_sole")
    foot_target.translation = foot_target.translation + LIFT
    rows = []
    for backend in available_backends():
        rows.append((f"wbik.qp [{backend}]", *ours(robot, q_start, foot_target, backend, args.repeats)))
    for backend in ("daqp", "osqp"):
        try:
            result = pink_run(robot, q_start, foot_target, args.repeats, backend)
            rows.append((f"Pink 4.4 [{backend}]", *result))
        except Exception as exc:  # report, keep the table
            print(f"Pink [{backend}] failed: {exc}")
    rows.append(("PlaCo 0.10.2 (C++)", *placo_run(robot, q_start, foot_target, args.repeats)))
    placo_step, placo_ik = rows[-1][1], rows[-1][2]
    pink_rows = [r for r in rows if r[0].startswith("Pink") and "daqp" in r[0]]
    pink_step = pink_rows[0][1] if pink_rows else float("nan")
    print(f"Bioloid whole body, nv = {robot.model.nv}; right sole hard, CoM in right sole -5 mm "
          f"(not Pink), left foot +40 mm, pelvis orientation, limits. Median of {args.repeats} steps.")
    header = (f"{'solver':24s} {'ms/step':>9s} {'x PlaCo':>8s} {'x Pink':>7s} {'ms/IK':>8s} "
              f"{'x PlaCo':>8s} {'iters':>6s} {'ok':>4s} {'foot err':>9s} {'CoM mm':>7s}")
    print(header)
    print("-" * len(header))
    for name, step, ik, iterations, ok, error, margin in rows:
        print(f"{name:24s} {step * 1e3:9.4f} {step / placo_step:8.1f} {step / pink_step:7.2f} "
              f"{ik * 1e3:8.3f} {ik / placo_ik:8.1f} {iterations:6d} {'yes' if ok else 'no':>4s} "
              f"{error:9.1e} {margin * 1e3:7.3f}")
    print("CoM mm: the final CoM's margin in the right sole (wbik SupportPolygon, by FK; need >= 5 mm "
          "except Pink, which has no polygon constraint).")
    print("Settings.", PINK_SETTINGS)
    print("Settings.", PLACO_SETTINGS)
    ours_rows = [r for r in rows if r[0].startswith("wbik")]
    fastest = min(ours_rows, key=lambda r: r[1])
    phase_table(robot, q_start, foot_target, args.repeats)
    print(f"fastest backend here: {fastest[0]} ({fastest[1] * 1e3:.4f} ms/step, "
          f"{1.0 / fastest[1]:.0f} Hz); use backend='fastest' (wbik.qp.backends.FASTEST)")


if __name__ == "__main__":
    main()
