"""Whole-body QP IK on the Bioloid (nv = 24): our QP per backend vs Pink (pin-pink) vs PlaCo.

Same tasks for all, same run: the robot stands on the right foot (its CoM first moved over it),
the right sole is a hard contact, the left sole has a frame task 40 mm up, the pelvis keeps its
orientation (soft, weight 0.1), small regularisation, joint limits. Ours and PlaCo also hold the
CoM inside the right sole shrunk by 5 mm (hard); Pink has no support-polygon constraint, so it
runs without it (it is inactive at this configuration anyway: the CoM stays > 10 mm inside).

Printed: time per QP step and per converged IK, with ratios to PlaCo and to Pink, the final foot
error, contact drift and CoM margin in the right sole by FK (wbik's SupportPolygon), and Pink's and
PlaCo's settings. PlaCo gets its CoM polygon clockwise, as its CoMPolygonConstraint wants, and
configured hard (its default priority is soft); ``placo_problem`` builds that problem
(tests/test_peer_configuration.py too).

What a figure counts, for every solver alike:
- a QP step: the kinematics at the start configuration (FK, Jacobians, CoM) + building the QP +
  solving it (ours: ``IKProblem.step(q)``; PlaCo: ``update_kinematics()`` + ``solve(False)``; Pink:
  ``Configuration.update(q)`` + ``solve_ik``);
- a converged IK: from the start configuration until the foot error is <= 1e-6 m and 1e-6 rad
  (the same final accuracy for all: our foot task's tolerance is 1e-6 on |e|, which bounds both;
  PlaCo's and Pink's loops test both norms after every step), our answer verified by FK
  (contacts within 1e-10, CoM margin, limits) inside the timed call.
Timing: the contenders are interleaved, ``rounds`` times; each round takes the median of
``repeats`` calls; the figure is the best round (the machine is shared: best-of-N limits the load's
effect on the ratios, which is what carries over to another machine).

Then where our time goes: a table of the phases (kinematics, constraint rows, task rows, H and c,
the DAQP call; ``profile`` of IKProblem.step and IKProblem.solve) per step and per converged IK,
where the IK adds its start, the contact projections, the merit and constraint checks by FK, the
report and the rest of the loop (step size, integration); ``ratios`` prints it too, so
``benchmarks/all.py --only qp`` shows it. ``cProfile`` on ``problem.step`` / ``problem.solve``
gives the same picture by function.

Run: .venv/bin/python benchmarks/qp.py [--repeats 300] [--rounds 5]
``ratios(quick)`` gives wbik's goals as Ratio figures for benchmarks/all.py.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np
import pinocchio as pin

import wbik
from wbik.qp import (
    ComTask,
    FrameTask,
    IKProblem,
    OrientationTask,
    PositionTask,
    RegularizationTask,
    available_backends,
)
from wbik.qp.humanoid import stance_constraints, support_polygon
from wbik.qp.problem import PHASES, SOLVE_PHASES

MARGIN = 0.005
LIFT = np.array([0.0, 0.0, 0.04])
ACCURACY = 1e-6
"""The converged IK's final foot accuracy (m and rad), the same for every solver."""
STEP_RATE = 5000.0
"""wbik's floor on our QP steps per second (Hz)."""


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


def median_time(function, repeats: int) -> float:
    """Median time of one call (s) over ``repeats`` calls."""
    times = np.empty(repeats)
    for i in range(repeats):
        start = time.perf_counter()
        function()
        times[i] = time.perf_counter() - start
    return float(np.median(times))


def interleaved(contenders: dict, repeats: dict, rounds: int) -> dict[str, float]:
    """Best over ``rounds`` of each contender's median time, the contenders taking turns."""
    from ratios import best_of_rounds

    return best_of_rounds({name: (lambda name=name, function=function: median_time(function, repeats[name]))
                           for name, function in contenders.items()}, rounds)


def our_problem(robot, q_start, foot_target, backend="daqp") -> IKProblem:
    pelvis = robot.frame_placement(q_start, "pelvis").rotation
    return IKProblem(robot.model, [FrameTask("l_sole", foot_target, tolerance=ACCURACY),
                                   OrientationTask("pelvis", pelvis, weight=0.1, goal=False),
                                   RegularizationTask(1e-6)],
                     stance_constraints(robot, q_start, ["r_sole"], margin=MARGIN), backend=backend)


def foot_error(robot, q, target) -> float:
    reached = robot.frame_placement(q, "l_sole")
    return float(max(np.linalg.norm(reached.translation - target.translation),
                     np.linalg.norm(pin.log3(target.rotation.T @ reached.rotation))))


def contact_drift(robot, q, q_start) -> float:
    """How far the right sole moved from its start pose (max of m and rad), by FK."""
    held, reached = robot.frame_placement(q_start, "r_sole"), robot.frame_placement(q, "r_sole")
    return float(max(np.linalg.norm(reached.translation - held.translation),
                     np.linalg.norm(pin.log3(held.rotation.T @ reached.rotation))))


class Contender(SimpleNamespace):
    """One solver on the benchmark: ``name``, ``step()``, ``converge()`` (a converged IK from the
    start; returns its iterations) and ``answer()`` (the q of the last converge, read outside the
    timing); PlaCo's also ``copy()``, the configuration copy its converge includes (timed in the same
    interleaved rounds and subtracted)."""

    def __init__(self, name: str, step, converge, answer):
        super().__init__(name=name, step=step, converge=converge, answer=answer)


class Row(NamedTuple):
    name: str
    step_s: float
    ik_s: float
    iterations: int
    foot_error: float
    drift: float
    com_margin: float

    @property
    def ok(self) -> bool:
        return self.foot_error <= ACCURACY


def ours(robot, q_start, foot_target, backend: str) -> Contender:
    problem = our_problem(robot, q_start, foot_target, backend)
    problem.start(q_start)

    last = {}

    def converge():
        last["solution"] = solution = problem.solve(q_start)
        return solution.iterations

    return Contender(f"wbik.qp [{backend}]", lambda: problem.step(q_start, dt=1.0), converge,
                     lambda: last["solution"].q)


def pink_contender(robot, q_start, foot_target, solver="daqp") -> Contender:
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

    def one_step():
        configuration.update(q_start)
        pink.solve_ik(configuration, [left, pelvis], 1.0, solver=solver, damping=1e-6,
                      constraints=[right], limits=limits, safety_break=False)

    last = {}

    def converge():
        config = pink.Configuration(model, data, q_start.copy())
        for iteration in range(1, 201):
            v = pink.solve_ik(config, [left, pelvis], 1.0, solver=solver, damping=1e-6,
                              constraints=[right], limits=limits, safety_break=False)
            last["q"] = q = pin.integrate(model, config.q, v)
            config.update(q)
            if foot_error(robot, q, foot_target) <= ACCURACY:
                return iteration
        return 200

    return Contender(f"Pink 4.4 [{solver}]", one_step, converge, lambda: last["q"])


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


def placo_contender(robot, q_start, foot_target) -> Contender:
    from wbik.solvers.placo import placo_configuration, set_placo_configuration

    setup = placo_problem(robot, q_start, foot_target)
    wrapper, solver, left = setup.wrapper, setup.solver, setup.left
    set_placo_configuration(robot, wrapper, q_start)

    def one_step():  # solve(False) leaves the configuration where it is
        wrapper.update_kinematics()
        solver.solve(False)

    def converge():
        # the configuration copy (by joint name, from Python) is not PlaCo's cost: it is undone
        # here and timed apart by the caller (copy)
        set_placo_configuration(robot, wrapper, q_start)
        for iteration in range(1, 201):
            solver.solve(True)
            wrapper.update_kinematics()
            if np.linalg.norm(left.position().error()) <= ACCURACY and np.linalg.norm(
                    left.orientation().error()) <= ACCURACY:
                return iteration
        return 200

    contender = Contender("PlaCo 0.10.2 (C++)", one_step, converge,
                          lambda: placo_configuration(robot, wrapper))
    contender.copy = lambda: set_placo_configuration(robot, wrapper, q_start)
    return contender


def measure(robot, q_start, foot_target, contenders: list[Contender], repeats: int, rounds: int) -> list[Row]:
    """Every contender's step and converged IK, interleaved, with its answer checked by FK."""
    polygon = support_polygon(robot, q_start, ["r_sole"])
    answers = {c.name: (c.converge(), c.answer()) for c in contenders}  # (warms every contender up)
    # the copy a converge includes, best of the same rounds as the converge (a copy timed once, apart,
    # took the load of that moment and moved PlaCo's IK figure by tens of percent); first in each
    # round, so PlaCo's steps start from q_start like everyone's
    calls = {f"{c.name} copy": c.copy for c in contenders if hasattr(c, "copy")}
    calls.update({f"{c.name} step": c.step for c in contenders})
    calls.update({f"{c.name} ik": (lambda c=c: c.converge()) for c in contenders})
    counts = {name: repeats if name.endswith(("step", "copy")) else max(repeats // 10, 5) for name in calls}
    times = interleaved(calls, counts, rounds)
    rows = []
    for contender in contenders:
        ik = times[f"{contender.name} ik"]
        if hasattr(contender, "copy"):
            ik -= times[f"{contender.name} copy"]
        iterations, q = answers[contender.name]
        rows.append(Row(contender.name, times[f"{contender.name} step"], ik, iterations,
                        foot_error(robot, q, foot_target), contact_drift(robot, q, q_start),
                        com_margin_by_fk(robot, q, polygon)))
    return rows


def phase_table(robot, q_start, foot_target, repeats: int) -> None:
    """Where our time goes (DAQP): one QP step by phase (IKProblem.step's ``profile``: PHASES), and
    one converged IK (IKProblem.solve's ``profile``) split into its steps' phases (kinematics: the
    update after each step; tasks: the rows the merit test and the next step share) and the loop's
    own (SOLVE_PHASES: start, contact projections, merit and constraint checks by FK, report); the
    rest is the loop's bookkeeping (step size, integration, clipping) and the clock's own cost."""
    problem = our_problem(robot, q_start, foot_target)
    problem.start(q_start)
    steps: dict[str, float] = {}
    for _ in range(repeats):
        problem.step(q_start, dt=1.0, profile=steps)
    solves = max(repeats // 10, 5)
    inside: dict[str, float] = {}
    total = 0.0
    for _ in range(solves):
        start = time.perf_counter()
        solution = problem.solve(q_start, profile=inside)
        total += time.perf_counter() - start
    inside["rest"] = total - sum(inside.values())
    print(f"Where the time goes (wbik.qp [daqp], us; mean of {repeats} steps and {solves} IK solves of "
          f"{solution.iterations} iterations):")
    print(f"{'phase':22s} {'per step':>9s} {'share':>6s} {'per IK':>9s} {'share':>6s}")
    step_total = sum(steps.values())
    for phase in (*PHASES, *SOLVE_PHASES, "rest"):
        per_step = steps.get(phase, 0.0) / repeats
        per_ik = inside.get(phase, 0.0) / solves
        print(f"{phase:22s} {per_step * 1e6:9.1f} {per_step / (step_total / repeats):6.0%} "
              f"{per_ik * 1e6:9.1f} {per_ik / (total / solves):6.0%}")
    print(f"{'total':22s} {step_total / repeats * 1e6:9.1f} {'':6s} {total / solves * 1e6:9.1f}")


TALOS_TASK = Path(__file__).resolve().parents[1] / "tasks" / "talos_reach.yaml"


def talos_reach_steps():
    """One QP step of the first reach of tasks/talos_reach.yaml (Talos from half-sitting, nv 38, both soles
    held, the right gripper to a point, the trunk's orientation soft at 0.1, regularisation 1e-6, joint
    limits, the CoM 20 mm inside the soles' polygon, hard), ours and PlaCo's, as ``{name: step}``."""
    from wbik.scenarios import load_scenario
    from wbik.scenarios.kinds import robot_of, start_of
    from wbik.scenarios.schema import validate
    from wbik.solvers.placo import import_placo, placo_robot

    spec = validate(load_scenario(TALOS_TASK), str(TALOS_TASK))
    robot = robot_of(spec)
    q, margin, soles = start_of(spec, robot), float(spec["margin"]), list(robot.soles)
    reach = spec["phases"][0]["tasks"][0]
    frame, target = reach["frame"], np.asarray(reach["target"], dtype=float)
    trunk = robot.frame_placement(q, "base_link").rotation
    problem = IKProblem(robot.model, [PositionTask(frame, target),
                                      OrientationTask("base_link", trunk, weight=0.1, goal=False),
                                      RegularizationTask(1e-6)],
                        stance_constraints(robot, q, soles, margin=margin), backend="daqp")
    problem.start(q)
    placo = import_placo()
    wrapper = placo_robot(robot, q)
    solver = placo.KinematicsSolver(wrapper)
    solver.enable_joint_limits(True)
    for sole in soles:
        solver.add_frame_task(sole, robot.frame_placement(q, sole).homogeneous).configure(sole, "hard", 1.0)
    solver.add_position_task(frame, target).configure("reach", "soft", 1.0)
    solver.add_orientation_task("base_link", trunk).configure("trunk", "soft", 0.1)
    vertices = placo_polygon(support_polygon(robot, q, soles))
    solver.add_com_polygon_constraint(vertices, margin).configure("com_polygon", "hard", 1.0)
    solver.add_regularization_task(1e-6)

    def placo_step():
        wrapper.update_kinematics()
        solver.solve(False)

    return {"ours": lambda: problem.step(q, dt=1.0), "placo": placo_step}


def bench_setup():
    robot = wbik.load("bioloid")
    q_start = stand_on_right_foot(robot)
    foot_target = robot.frame_placement(q_start, "l_sole")
    foot_target.translation = foot_target.translation + LIFT
    return robot, q_start, foot_target


def ratios(quick: bool = False) -> list:
    """wbik's whole-body QP goals as ratios to PlaCo and Pink (DAQP),
    measured in this process: ours with DAQP, interleaved, best of several rounds."""
    from ratios import Ratio

    robot, q_start, foot_target = bench_setup()
    repeats, rounds = (300, 5) if quick else (1000, 9)
    rows = {row.name.split(" ")[0]: row for row in measure(
        robot, q_start, foot_target, [ours(robot, q_start, foot_target, "daqp"),
                                      pink_contender(robot, q_start, foot_target, "daqp"),
                                      placo_contender(robot, q_start, foot_target)], repeats, rounds)}
    us, pink, placo = rows["wbik.qp"], rows["Pink"], rows["PlaCo"]
    talos = interleaved(talos_reach_steps(), dict.fromkeys(("ours", "placo"), repeats // 2), rounds)
    phase_table(robot, q_start, foot_target, repeats)  # where our time goes
    how = (f"Bioloid on one foot, nv 24; best of {rounds} interleaved rounds of the median of "
           f"{repeats} steps / {max(repeats // 10, 5)} IK solves")
    ik_note = (f"{how}; to foot error <= 1e-6 m and rad for all (ours {us.iterations} iterations, "
               f"{us.foot_error:.1e}; PlaCo {placo.iterations}, {placo.foot_error:.1e}; "
               f"Pink {pink.iterations}, {pink.foot_error:.1e})")
    return [
        Ratio("whole-body QP step <= 1.2x PlaCo", "wbik.qp step [daqp]", us.step_s, "PlaCo step",
              placo.step_s, "s/step", 1.2,
              note=how + "; PlaCo's polygon hard and clockwise; kinematics included for both"),
        Ratio("whole-body QP step <= 1.2x PlaCo (Talos two-feet reach)", "wbik.qp step [daqp]", talos["ours"],
              "PlaCo step", talos["placo"], "s/step", 1.2,
              note=(f"Talos nv 38, the first reach of tasks/talos_reach.yaml, both soles hard, CoM polygon "
                    f"hard (20 mm); best of {rounds} interleaved rounds of the median of {repeats // 2} "
                    "steps")),
        Ratio("whole-body QP step faster than Pink (DAQP)", "wbik.qp step [daqp]", us.step_s,
              "Pink step [daqp]", pink.step_s, "s/step", 1.0, note=how + "; Pink has no CoM polygon"),
        Ratio("converged whole-body IK <= 2x PlaCo", "wbik.qp IK [daqp]", us.ik_s, "PlaCo IK", placo.ik_s,
              "s/solve", 2.0, note=ik_note),
        Ratio("converged whole-body IK faster than Pink (DAQP)", "wbik.qp IK [daqp]", us.ik_s,
              "Pink IK [daqp]", pink.ik_s, "s/solve", 1.0, note=ik_note),
        Ratio("whole-body QP at least 5 kHz per step", "wbik.qp steps per second", 1.0 / us.step_s,
              "the goal's 5 kHz", STEP_RATE, "Hz", 1.0, better="higher", note=how),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    robot, q_start, foot_target = bench_setup()
    contenders = [ours(robot, q_start, foot_target, backend) for backend in available_backends()]
    for backend in ("daqp", "osqp"):
        try:
            contenders.append(pink_contender(robot, q_start, foot_target, backend))
        except Exception as exc:  # report, keep the table
            print(f"Pink [{backend}] failed: {exc}")
    contenders.append(placo_contender(robot, q_start, foot_target))
    rows = measure(robot, q_start, foot_target, contenders, args.repeats, args.rounds)
    placo, pink = rows[-1], next((r for r in rows if r.name == "Pink 4.4 [daqp]"), None)
    pink_step = pink.step_s if pink else float("nan")
    pink_ik = pink.ik_s if pink else float("nan")
    print(f"Bioloid whole body, nv = {robot.model.nv}; right sole hard, CoM in right sole -5 mm "
          f"(not Pink), left foot +40 mm, pelvis orientation, limits. Best of {args.rounds} interleaved "
          f"rounds of the median of {args.repeats} steps / {max(args.repeats // 10, 5)} IK solves.")
    header = (f"{'solver':24s} {'ms/step':>9s} {'x PlaCo':>8s} {'x Pink':>7s} {'ms/IK':>8s} "
              f"{'x PlaCo':>8s} {'x Pink':>7s} {'iters':>6s} {'ok':>4s} {'foot err':>9s} {'drift':>8s} "
              f"{'CoM mm':>7s}")
    print(header)
    print("-" * len(header))
    for row in rows:
        print(f"{row.name:24s} {row.step_s * 1e3:9.4f} {row.step_s / placo.step_s:8.1f} "
              f"{row.step_s / pink_step:7.2f} {row.ik_s * 1e3:8.3f} {row.ik_s / placo.ik_s:8.1f} "
              f"{row.ik_s / pink_ik:7.2f} {row.iterations:6d} {'yes' if row.ok else 'no':>4s} "
              f"{row.foot_error:9.1e} {row.drift:8.1e} {row.com_margin * 1e3:7.3f}")
    print(f"ok: foot error <= {ACCURACY:g} m and rad (the same stopping accuracy for all). drift: the right "
          "sole's contact error by FK (m or rad). CoM mm: the final CoM's margin in the right sole (wbik "
          "SupportPolygon, by FK; need >= 5 mm except Pink, which has no polygon constraint).")
    print("Settings.", PINK_SETTINGS)
    print("Settings.", PLACO_SETTINGS)
    fastest = min((r for r in rows if r.name.startswith("wbik")), key=lambda r: r.step_s)
    phase_table(robot, q_start, foot_target, args.repeats)
    print(f"fastest backend here: {fastest.name} ({fastest.step_s * 1e3:.4f} ms/step, "
          f"{1.0 / fastest.step_s:.0f} Hz); use backend='fastest' (wbik.qp.backends.FASTEST)")


if __name__ == "__main__":
    main()
