"""Write the notebooks of notebooks/ (without outputs) from the cell sources below.

    .venv/bin/python scripts/make_notebooks.py          # (re)write every notebook
    .venv/bin/python scripts/make_notebooks.py --check  # exit 1 when a committed notebook differs

The notebooks are executed by tests/test_notebooks.py (nbclient); the seed numbers they reproduce
are asserted in the cells, so an executed notebook is a test too. Each notebook finds the repository
root itself, so it runs from notebooks/ (Jupyter, the tests) or from the root.
notebooks/06_ur5_riveting.ipynb is written elsewhere and is not touched here.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"

ROOT_FINDER = """\
ROOT = next(folder for folder in (Path.cwd(), *Path.cwd().parents) if (folder / "pyproject.toml").exists())
ARTIFACTS = ROOT / "tests" / "artifacts" / "notebooks"
"""


def md(text: str) -> tuple[str, str]:
    return "markdown", textwrap.dedent(text).strip("\n")


def code(*parts: str) -> tuple[str, str]:
    return "code", "\n\n".join(textwrap.dedent(part).strip("\n") for part in parts)


# --------------------------------------------------------------------------------------------------
def quickstart() -> list[tuple[str, str]]:
    return [
        md("""
        # 1. Quickstart: a robot, forward kinematics, three IK methods, a view

        This notebook loads the Golem-III upper body (the thesis's DH table, seed 000) and computes
        forward kinematics, checked here against the thesis's closed-form equations. It then solves
        one pose with three methods (the closed form, TRAC-IK and our bounded Levenberg-Marquardt)
        and compares their answers under the shared FK check. Last, it draws the robot with the
        target in an inline 3-D view.
        """),
        code("""
        import matplotlib.pyplot as plt
        import numpy as np
        import pinocchio as pin

        import wbik

        robot = wbik.load("golem3")
        print("robots:", ", ".join(wbik.robots()))
        print("golem3 chains:", {name: spec.joints for name, spec in robot.chains.items()})
        print("methods:", ", ".join(wbik.methods()))
        chain = robot.chain("right_arm")     # torso_link -> r_eef: chest yaw m0 + m10..m14
        print(chain.joint_names, chain.base_frame, "->", chain.tip_frame)
        """),
        md("""
        ## Forward kinematics

        `chain.fk(q)` gives the tip pose in the chain's base frame (a `pin.SE3`). The thesis writes
        the gripper position and orientation in closed form (golem3.md: eq. 3.3-3.9 with two
        misprints corrected, R = Rz(gamma) Ry(beta) Rx(alpha)); the cell below types those
        equations in and asserts that both agree.
        """),
        code("""
        def thesis_fk(t):
            \"\"\"Thesis eq. 3.3-3.9 (golem3.md): gripper position (m) and rotation of the right arm.\"\"\"
            h, l1, l2, l4, l5, l6, rho = 1.283, 0.1225, 0.212, 0.256, 0.034, 0.4, np.radians(13.43)
            t1, t2, t3, t4, t5, t6 = t
            l3 = l4 * np.sin(t4 + rho) + l5 * np.sin(t4 + t5) + l6 * np.cos(t4 + t5)
            x = l1 * np.sin(t1) + l2 * np.sin(t1 + t2) + l3 * np.cos(t1 + t2 + t3)
            y = -l1 * np.cos(t1) - l2 * np.cos(t1 + t2) + l3 * np.sin(t1 + t2 + t3)
            z = h - l4 * np.cos(t4 + rho) - l5 * np.cos(t4 + t5) + l6 * np.sin(t4 + t5)
            gamma, beta, alpha = t1 + t2 + t3, -t4 - t5, t6
            return np.array([x, y, z]), pin.rpy.rpyToMatrix(alpha, beta, gamma)

        q = np.array([0.3, -0.4, 1.2, 0.5, -0.6, 0.7])
        pose = chain.fk(q)
        position, rotation = thesis_fk(q)
        print("FK position (m):", pose.translation.round(6))
        print("thesis      (m):", position.round(6))
        print("rotation:\\n", pose.rotation.round(4))
        assert np.allclose(pose.translation, position, atol=1e-12)
        assert np.allclose(pose.rotation, rotation, atol=1e-12)
        """),
        md("""
        ## Inverse kinematics with three methods

        The target is the FK of random joints inside the limits, so it has a solution. Every
        method returns the same `IKResult`, and `success` comes from one FK check shared by all
        methods (1e-6 m and 1e-6 rad). The closed form returns the branch nearest to `q0`.
        The numerical methods may settle on another branch: their joints can differ and still
        reach the same pose.
        """),
        code("""
        rng = np.random.default_rng(7)
        q_true = chain.random(rng)
        target = chain.fk(q_true)
        q0 = chain.nominal
        results = {}
        for method in ("analytic", "trac_ik", "bounded_lm", "kdl"):
            solver = wbik.solver(method, robot, chain="right_arm", timeout_s=0.5)  # default budget: 5 ms
            results[method] = solver.solve(target, q0)

        print(f"{'method':<11} {'ok':<5} {'|dp| (m)':>9} {'|dR| (rad)':>10} {'time (ms)':>9}  q (rad)")
        for method, result in results.items():
            q_text = "-" if result.q is None else np.array2string(result.q, precision=3, suppress_small=True)
            print(f"{method:<11} {result.success!s:<5} {result.position_error:9.1e} "
                  f"{result.rotation_error:10.1e} {result.time_s * 1e3:9.3f}  {q_text}")
        for method in ("analytic", "trac_ik", "bounded_lm"):
            result = results[method]
            assert result.success, (method, result.reason)
            assert result.position_error <= 1e-6 and result.rotation_error <= 1e-6
            assert chain.in_limits(result.q)
        if not results["kdl"].success:
            print("kdl (one NR_JL attempt from q0):", results["kdl"].reason)
        """),
        md("""
        How far apart are the answers in joint space? The closed form also lists every branch
        (`solve_all`); each of them reaches the target.
        """),
        code("""
        reference = results["analytic"].q
        for method in ("trac_ik", "bounded_lm"):
            print(f"max |q_{method} - q_analytic| = {np.abs(results[method].q - reference).max():.2e} rad")
        branches = wbik.solver("analytic", robot, chain="right_arm").solve_all(target)
        print(len(branches), "closed-form branches inside the limits")
        for branch in branches:
            q_text = np.array2string(branch.q, precision=3, suppress_small=True)
            print(q_text, f"|dp| = {branch.position_error:.1e}")
            assert branch.success
        assert any(np.allclose(branch.q, q_true, atol=1e-6) for branch in branches)
        """),
        code("""
        fig, (ax_error, ax_time) = plt.subplots(1, 2, figsize=(10, 3.2))
        names = list(results)
        floor = 1e-17  # exact answers drawn at the floor of the log axis
        ax_error.bar(np.arange(len(names)) - 0.2, [max(results[n].position_error, floor) for n in names], 0.4,
                     label="position (m)")
        ax_error.bar(np.arange(len(names)) + 0.2, [max(results[n].rotation_error, floor) for n in names], 0.4,
                     label="rotation (rad)")
        ax_error.axhline(1e-6, color="k", lw=0.8, ls="--", label="shared FK check")
        ax_error.set(yscale="log", xticks=range(len(names)), xticklabels=names, title="error of the answer")
        ax_error.legend(fontsize=8)
        ax_time.bar(names, [results[n].time_s * 1e3 for n in names], color="tab:gray")
        ax_time.set(ylabel="ms", title="time of the call (first call, one pose)")
        fig.tight_layout()
        """),
        md("""
        A position-only target (a 3-vector) leaves the orientation free. Bad input raises a typed
        `wbik` error that says what to fix; an unreachable target returns `success=False` with a
        reason.
        """),
        code("""
        lm = wbik.solver("bounded_lm", robot, chain="right_arm", timeout_s=0.5)
        position_only = lm.solve(target.translation, q0)
        print("position only:", position_only.success, f"{position_only.position_error:.1e} m")
        assert position_only.success

        far = wbik.solver("bounded_lm", robot, chain="right_arm").solve([3.0, 0.0, 1.0], q0)
        print("3 m away:", far.success, "-", far.reason)
        assert not far.success and far.reason

        try:
            wbik.solver("bounded_lm", robot, chain="right_arm").solve([np.nan, 0.0, 1.0])
        except wbik.WbikError as error:
            print(type(error).__name__, "-", error)
        """),
        md("""
        ## View

        `wbik.viz.Viewer` records a meshcat scene without a server, and in a notebook it displays
        itself inline as a self-contained page. The green triad is the target; the blue triad is
        the pose the closed form's answer reaches.
        """),
        code("""
        from wbik.viz import Viewer

        viewer = Viewer(robot)
        viewer.show_ik_result(results["analytic"], target, "right_arm")
        viewer
        """),
    ]


# --------------------------------------------------------------------------------------------------
SEED_001_ANGLES = """\
        SEED_ANGLES_EPS_0_1 = np.array([  # angles.txt (seed 001, Figure 7): 31 rows for eps = 0.1
            [1.5708, 1.5708, 1.5708], [1.6708, 1.6208, 1.6208], [1.75614, 1.69991, 1.63712],
            [1.83087, 1.79347, 1.63065], [1.89688, 1.89866, 1.60178], [1.95508, 2.01276, 1.55047],
            [2.00648, 2.13363, 1.47668], [2.05198, 2.26014, 1.37988], [2.09239, 2.39243, 1.25838],
            [2.12842, 2.53232, 1.10829], [2.16067, 2.6843, 0.921095], [2.12793, 2.61251, 1.1143],
            [2.09184, 2.56526, 1.27329], [2.05141, 2.53194, 1.41224], [2.00586, 2.51134, 1.53404],
            [1.9544, 2.50263, 1.64088], [1.89611, 2.5055, 1.7337], [1.83002, 2.51971, 1.81277],
            [1.75513, 2.54484, 1.87781], [1.67053, 2.58009, 1.92827], [1.57562, 2.62401, 1.96342],
            [1.57077, 2.46655, 2.03598], [1.5708, 2.30154, 2.08431], [1.5708, 2.14008, 2.10636],
            [1.5708, 1.98921, 2.10189], [1.5708, 1.85616, 2.07116], [1.5708, 1.74639, 2.01559],
            [1.5708, 1.6624, 1.93728], [1.5708, 1.60421, 1.83815], [1.5708, 1.57049, 1.71934],
            [1.5708, 1.55971, 1.58079]])
        SEED_VISITED = {  # "Visited points:" printed by the seed (Figures 8 and 9)
            0.1: np.array([[-2.44929e-16, -2, 5], [1.99318, -2.9777, 2.98835], [0.208905, -2.08772, 2.10641],
                           [-2.07174e-16, -1.97703, 4.40638]]),
            1e-12: np.array([[-2.44929e-16, -2, 5], [2, -3, 3], [0.2, -2.1, 2.1], [2.01609e-16, -2, 4.96]]),
        }
"""


def newton_path() -> list[tuple[str, str]]:
    return [
        md("""
        # 5. Newton-Raphson path of seed 001: visited points versus requested ones

        Seed 001 moves a 3-joint arm (l = 3, 2, 2) from P0 = (0, -2, 5) through P1 = (2, -3, 3),
        P2 = (0, -2, 2) and P3 = (0, -2, 5). Each segment is split into 10 sub-points, and each
        sub-point is solved by Newton-Raphson from the previous answer. The seed's printed
        "visited points" miss P2 and P3, even at eps = 1e-12. This notebook reproduces the
        seed's table of angles row by row and finds where the miss comes from. It then shows that
        wbik's `newton` with `follow_path` reaches every waypoint to 1e-9.
        """),
        code("""
        import matplotlib.pyplot as plt
        import numpy as np

        import wbik
        from wbik.models import arm3r
        from wbik.solvers.newton import newton_step
        from wbik.solvers.path import follow_path

        robot = wbik.load("arm3r")                 # lengths (3, 2, 2), the seed's worked example
        chain = robot.chain("arm")
        START = arm3r.start_configuration()          # theta = (pi/2, pi/2, pi/2)
        P0 = chain.fk(START).translation
        WAYPOINTS = np.array([[2.0, -3.0, 3.0], [0.0, -2.0, 2.0], [0.0, -2.0, 5.0]])
        print("P0 =", P0.round(12))
        assert np.allclose(P0, [0.0, -2.0, 5.0], atol=1e-12)
        """),
        code(SEED_001_ANGLES),
        md("""
        ## The seed's loop, with wbik's kinematics

        For each segment and each sub-point k = 1..10, the loop iterates
        theta <- theta + J^-1 e until |e| <= eps. Here the step is `newton_step` (an LU solve)
        and J comes from the Pinocchio model, and every iterate is written as a row, as the seed
        wrote them. With eps = 0.1 this gives the seed's 31 rows to every printed digit.
        """),
        code("""
        def seed_loop(eps, substeps=10, max_iterations=100):
            \"\"\"The seed's continuation: one row per Newton iterate (the start is row 1).\"\"\"
            theta, rows = START.copy(), [START.copy()]
            points = np.vstack([P0, WAYPOINTS])
            for a, b in zip(points[:-1], points[1:], strict=True):
                for k in range(1, substeps + 1):
                    wanted = a + k / substeps * (b - a)
                    for _ in range(max_iterations):
                        pose, jacobian = chain.fk_jacobian(theta)
                        error = wanted - pose.translation
                        if np.linalg.norm(error) <= eps:
                            break
                        theta = theta + newton_step(jacobian[:3], error)
                        rows.append(theta.copy())
            return np.array(rows)

        rows = seed_loop(0.1)
        print(len(rows), "rows; largest difference to the seed's table:",
              f"{np.abs(rows - SEED_ANGLES_EPS_0_1).max():.1e} rad")
        assert rows.shape == SEED_ANGLES_EPS_0_1.shape == (31, 3)
        np.testing.assert_allclose(rows, SEED_ANGLES_EPS_0_1, atol=1e-5)
        """),
        md("""
        ## Where the waypoints went

        Rows 11, 21 and 31 (the 10th sub-point of each segment) reach P1, P2 and P3 within
        eps = 0.1, so the seed's angles do reach every waypoint. The printed "visited points" are
        FK of rows 1, 11, **20** and **29** instead. After the first segment the printout steps 9 rows
        instead of 10, an off-by-one in the printing and not in the solver. The seed's "worst
        error 0.5936 (z of P3)" is the distance to sub-point 8 of the last segment. At eps = 1e-12
        the printed (0.2, -2.1, 2.1) is again the 9th sub-point of segment 2, P1 + 0.9 (P2 - P1).
        The third printed point (z = 4.96) is no sub-point at all (those have z = 2.3, 2.6, ...,
        5.0). The report is not detailed enough to reconstruct how that run printed it.
        """),
        code("""
        tips = np.array([chain.fk(row).translation for row in rows])
        segment_ends = [10, 20, 30]  # 0-based rows of the 10th sub-point of each segment
        for index, point in zip(segment_ends, WAYPOINTS, strict=True):
            gap = np.linalg.norm(tips[index] - point)
            print(f"row {index + 1}: {tips[index].round(5)}  wanted {point}  |e| = {gap:.4f}")
            assert gap <= 0.1
        printed_rows = [0, 10, 19, 28]
        np.testing.assert_allclose(tips[printed_rows], SEED_VISITED[0.1], atol=1e-5)
        print("seed's printed points = FK of rows", [index + 1 for index in printed_rows])
        assert np.isclose(5.0 - tips[28, 2], 0.5936, atol=1e-4)   # the seed's "worst error"
        # eps = 1e-12: the seed's loop run here; the printed third point is one of its rows
        tight = np.array([chain.fk(row).translation for row in seed_loop(1e-12)])
        gaps = np.linalg.norm(tight - SEED_VISITED[1e-12][2], axis=1)
        print(f"eps = 1e-12: {len(tight)} rows; row {gaps.argmin() + 1} is the printed",
              SEED_VISITED[1e-12][2], f"to {gaps.min():.1e}")
        assert gaps.min() <= 1e-9
        """),
        md("""
        ## wbik's path: every waypoint to 1e-9

        `follow_path` splits each segment the same way and makes the last sub-point the waypoint
        itself. Here `newton` runs with a 1e-9 FK check and a 1 s budget per sub-point, and each row is
        a solved sub-point.
        """),
        code("""
        solver = wbik.solver("newton", robot, tolerances=wbik.Tolerances(1e-9, 1e-9), timeout_s=1.0)
        path = follow_path(solver, WAYPOINTS, START, substeps=10)
        ours = np.array([chain.fk(q).translation for q in path.joints])
        print("success:", path.success, "| rows:", len(path.joints))
        assert path.success and len(path.joints) == 31, path.failures

        print(f"{'waypoint':<16} {'seed eps=0.1':>12} {'seed eps=1e-12':>15} {'wbik newton':>12}")
        for k, point in enumerate(WAYPOINTS):
            seed_coarse = np.linalg.norm(SEED_VISITED[0.1][k + 1] - point)
            seed_tight = np.linalg.norm(SEED_VISITED[1e-12][k + 1] - point)
            gap = np.linalg.norm(ours[segment_ends[k]] - point)
            print(f"P{k + 1} {str(point):<13} {seed_coarse:12.4f} {seed_tight:15.2e} {gap:12.1e}")
            assert gap <= 1e-9
        """),
        code("""
        fig = plt.figure(figsize=(11, 4.5))
        ax = fig.add_subplot(1, 2, 1, projection="3d")
        requested = np.vstack([P0, WAYPOINTS])
        ax.plot(*tips.T, "-", color="tab:orange", lw=1, label="seed rows, eps = 0.1 (FK)")
        ax.plot(*ours.T, "-", color="tab:blue", lw=1, label="wbik newton")
        ax.scatter(*requested.T, s=80, facecolors="none", edgecolors="k", label="requested P0..P3")
        ax.scatter(*SEED_VISITED[0.1].T, marker="x", s=60, color="tab:red", label="seed printed, eps = 0.1")
        ax.scatter(*SEED_VISITED[1e-12].T, marker="+", s=80, color="tab:purple",
                   label="seed printed, eps = 1e-12")
        for k, point in enumerate(requested[:3]):
            ax.text(*point, f" P{k}")
        ax.set(xlabel="x", ylabel="y", zlabel="z", title="tip path of the seed-001 example")
        ax.legend(fontsize=7, loc="upper left")

        ax = fig.add_subplot(1, 2, 2)
        floor = 1e-16
        width = 0.27
        for offset, label, reached in ((-width, "seed printed, eps = 0.1", SEED_VISITED[0.1][1:]),
                                       (0.0, "seed printed, eps = 1e-12", SEED_VISITED[1e-12][1:]),
                                       (width, "wbik newton", ours[segment_ends])):
            gaps = np.linalg.norm(reached - WAYPOINTS, axis=1)
            ax.bar(np.arange(3) + offset, np.maximum(gaps, floor), width, label=label)
        ax.set(yscale="log", xticks=range(3), xticklabels=["P1", "P2", "P3"],
               ylabel="distance to the waypoint", title="waypoint error (floor 1e-16 = exact)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        """),
        md("""
        The seed did not guard against unreachable points, so its iteration never stopped on one.
        Here the path reports the waypoint it could not reach and carries on to the next.
        """),
        code("""
        unreachable = follow_path(solver, [WAYPOINTS[0], [0.0, 0.0, 12.0], WAYPOINTS[2]], START)
        print("reached:", unreachable.reached)
        print(unreachable.failures[-1])
        assert unreachable.reached == [True, False, True]
        """),
        md("The solved path as an animation (the yellow line is the tip's trace)."),
        code("""
        from wbik.viz import Viewer

        viewer = Viewer(robot)
        times = 0.1 * np.arange(len(path.joints))
        viewer.animate(times, path.joints, chain="arm", trace_frame=chain.tip_frame)
        viewer
        """),
    ]


# --------------------------------------------------------------------------------------------------
def pincher() -> list[tuple[str, str]]:
    return [
        md("""
        # 4. PhantomX Pincher: the seed's FK and IK examples, joint and linear moves

        This notebook covers the 4-DOF Pincher arm of seed 004 (DH model, tool frame `noa`,
        joints +-150 deg). It reproduces the seed's forward-kinematics check and its closed-form
        IK example, both asserted. It then runs the teleoperation's moves: a joint jog stopped
        at the limit, a straight TCP line in the reduced working plane (z = 137 mm, tool
        horizontal), and the automatic pick-and-place cycle, timed under velocity limits and
        plotted.
        """),
        code("""
        import math

        import matplotlib.pyplot as plt
        import numpy as np

        import wbik
        from wbik import motion
        from wbik.motion import pincher
        from wbik.solvers.analytic.pincher import pose_from_position_pitch

        robot = wbik.load("pincher")
        chain = robot.chain("arm")
        print(chain.joint_names, chain.base_frame, "->", chain.tip_frame)
        print("limits (deg):", np.degrees(chain.lower).round(1), np.degrees(chain.upper).round(1))
        """),
        md("""
        ## The seed's FK check

        q = [15, 30, 45, 60] deg gives p = [213.5636, 57.2242, 187.9335] mm and ZYZ Euler angles
        [15, 135, -180] deg (pincher.md). -180 and 180 deg are the same angle.
        """),
        code("""
        pose = chain.fk(np.radians([15.0, 30.0, 45.0, 60.0]))
        p_mm, R = pose.translation * 1000.0, pose.rotation
        zyz_deg = np.degrees([math.atan2(R[1, 2], R[0, 2]), math.atan2(math.hypot(R[0, 2], R[1, 2]), R[2, 2]),
                              math.atan2(R[2, 1], -R[2, 0])])
        print("p (mm):", p_mm.round(4))
        print("R:\\n", R.round(4))
        print("ZYZ (deg):", zyz_deg.round(4))
        np.testing.assert_allclose(p_mm, [213.5636, 57.2242, 187.9335], atol=1e-4)
        SEED_R = [[0.6830, 0.2588, 0.6830], [0.1830, -0.9659, 0.1830], [0.7071, 0.0, -0.7071]]
        np.testing.assert_allclose(R, SEED_R, atol=1e-4)
        wrapped = (zyz_deg - np.array([15.0, 135.0, -180.0]) + 180.0) % 360.0 - 180.0
        assert np.abs(wrapped).max() < 1e-6
        """),
        md("""
        ## The seed's IK example

        The seed's pose is [px, py, pz, theta] = [150, 200, 200] mm with a tool pitch of 60 deg.
        It gives q = [53.1301, 81.0504, 28.7724, -79.8228] deg. The seed's command line prints
        pz = 300, a typo: FK of that q is (150, 200, 200) mm. A 4-DOF arm cannot take every
        orientation, so the target is the full pose this position and pitch imply. The closed
        form finds both elbows, and the numerical methods reach the same pose.
        """),
        code("""
        SEED_Q_DEG = np.array([53.1301, 81.0504, 28.7724, -79.8228])
        target = pose_from_position_pitch([0.150, 0.200, 0.200], math.radians(60.0))
        analytic = wbik.solver("analytic", robot)
        result = analytic.solve(target, q0=np.radians(SEED_Q_DEG) + 0.05)
        print("analytic:", np.degrees(result.q).round(4), "deg")
        np.testing.assert_allclose(np.degrees(result.q), SEED_Q_DEG, atol=1e-4)
        seed_fk_mm = chain.fk(np.radians(SEED_Q_DEG)).translation * 1000
        np.testing.assert_allclose(seed_fk_mm, [150, 200, 200], atol=1e-2)  # pz = 200, not the printed 300

        for branch in analytic.solve_all(target):
            print("branch:", np.degrees(branch.q).round(4), "success:", branch.success)
        for method in ("bounded_lm", "trac_ik", "dls"):
            other = wbik.solver(method, robot, timeout_s=0.5).solve(target, q0=chain.mid_range)
            print(f"{method:<10}", other.success, np.degrees(other.q).round(4),
                  f"{other.time_s * 1e3:.2f} ms")
            assert other.success, other.reason
        """),
        md("""
        ## Joint moves

        A jog moves one joint and leaves the others where they are, stopping at the +-150 deg
        limit. Asking joint 2 for +200 deg moves it to 150 deg. `motion.joint_path` interpolates
        between whole configurations.
        """),
        code("""
        jog = pincher.jog(chain, np.zeros(4), "joint2", math.radians(200.0), samples=20)
        print({key: jog.info[key] for key in ("joint", "requested", "moved", "clipped")})
        assert jog.info["clipped"] and math.isclose(jog.q[-1, 1], math.radians(150.0))

        configurations = [np.zeros(4), np.radians([60, 30, 45, -20]), np.radians([-45, 60, 60, 30])]
        moves = motion.joint_path(chain, configurations, samples=20)
        fig, (ax_jog, ax_moves) = plt.subplots(1, 2, figsize=(10, 3.2), sharey=True)
        for name, column in zip(chain.joint_names, np.degrees(jog.q).T, strict=True):
            ax_jog.plot(jog.s, column, label=name)
        ax_jog.axhline(150, color="k", ls="--", lw=0.8)
        ax_jog.set(xlabel="path parameter s", ylabel="deg", title="jog joint2 by +200 deg (stops at 150)")
        for name, column in zip(chain.joint_names, np.degrees(moves.q).T, strict=True):
            ax_moves.plot(moves.s, column, label=name)
        ax_moves.set(xlabel="path parameter s", title="joint moves through two configurations")
        ax_moves.legend(fontsize=8)
        fig.tight_layout()
        """),
        md("""
        ## A linear move in the reduced working plane

        In the seed's reduced working plane the arm stays parallel to the floor. Read precisely,
        the TCP stays at z = 137 mm with the tool horizontal and pointing away from the base.
        The reachable band is 149.4 mm <= r <= 305 mm within +-150 deg around the base. The
        line below is solved knot by knot with the closed form, and each knot is asserted to lie
        on the straight line at 137 mm.
        """),
        code("""
        start_xy, goal_xy = np.array([0.25, -0.10]), np.array([0.15, 0.20])
        line = pincher.plane_line(analytic, start_xy, goal_xy, samples=20)
        tcp = np.array([chain.fk(q).translation for q in line.q])
        wanted = start_xy + line.s[:, None] * (goal_xy - start_xy)
        print("success:", line.success, "| largest deviation:", f"{np.abs(tcp[:, :2] - wanted).max():.1e} m")
        assert line.success
        assert np.allclose(tcp[:, :2], wanted, atol=1e-6)
        assert np.allclose(tcp[:, 2], pincher.PLANE_HEIGHT, atol=1e-6)

        fig, ax = plt.subplots(figsize=(5, 5))
        angles = np.linspace(-pincher.PLANE_SECTOR, pincher.PLANE_SECTOR, 200)
        for radius in (pincher.PLANE_MIN_RADIUS, pincher.PLANE_REACH):
            ax.plot(radius * np.cos(angles) * 1e3, radius * np.sin(angles) * 1e3, "k--", lw=0.8)
        ax.plot(tcp[:, 0] * 1e3, tcp[:, 1] * 1e3, "o-", ms=3, label="TCP at the knots")
        ax.plot(0, 0, "ks", label="base axis")
        ax.set(aspect="equal", xlabel="x (mm)", ylabel="y (mm)",
               title="linear move at z = 137 mm (band dashed)")
        ax.legend(fontsize=8)

        beyond = pincher.plane_line(analytic, start_xy, (0.32, 0.10), samples=10)
        print("a line beyond 305 mm:", beyond.success, "-", next(iter(beyond.info["outside_plane"].values())))
        assert not beyond.success
        """),
        md("""
        ## The automatic cycle, timed

        The automatic mode is a fixed pick-and-place cycle of straight TCP segments with the tool
        pointing down. The seed gives no numbers for it, so the points are our choice. The joint
        path is timed with a quintic law under a 2 rad/s joint speed limit, and then sampled
        every 50 ms.
        """),
        code("""
        cycle = pincher.automatic_path(analytic, samples=10)
        assert cycle.success, cycle.summary()
        for knot, point in zip(cycle.waypoint_knots, pincher.AUTOMATIC_CYCLE[1:], strict=True):
            assert np.allclose(chain.fk(cycle.q[knot]).translation, point[:3], atol=1e-6)
        timed = motion.time_scale(cycle, "quintic", velocity_limit=2.0, mode="waypoint")
        trajectory = motion.make_trajectory(timed, dt=0.05)
        print(f"duration {trajectory.duration:.2f} s, {len(trajectory.times)} points, "
              f"peak speed {np.abs(trajectory.velocities).max():.3f} rad/s")
        assert np.abs(trajectory.velocities).max() <= 2.0 + 1e-6

        fig = plt.figure(figsize=(11, 4))
        ax = fig.add_subplot(1, 2, 1)
        for name, column in zip(chain.joint_names, np.degrees(trajectory.positions).T, strict=True):
            ax.plot(trajectory.times, column, label=name)
        ax.set(xlabel="t (s)", ylabel="deg", title="joint positions")
        ax.legend(fontsize=8)
        ax = fig.add_subplot(1, 2, 2, projection="3d")
        ax.plot(*(trajectory.tip_positions * 1e3).T, lw=1, label="TCP (FK of the samples)")
        ax.scatter(*(np.array(pincher.AUTOMATIC_CYCLE)[:, :3] * 1e3).T, color="k", s=20, label="cycle points")
        ax.set(xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)", title="TCP path of the cycle")
        ax.legend(fontsize=8)
        fig.tight_layout()
        """),
        md("The timed cycle in the viewer; the yellow line is the TCP's trace."),
        code("""
        from wbik.viz import Viewer

        viewer = Viewer(robot)
        viewer.play(trajectory)
        viewer
        """),
    ]


# --------------------------------------------------------------------------------------------------
def thesis_study() -> list[tuple[str, str]]:
    return [
        md("""
        # 2. The thesis study, small: every method on the same Golem-III poses

        The Golem-III thesis (seed 000, ch. 5) gave 10,000 reachable poses of the right arm to
        its closed form and to KDL. It reports 94 % solved with a median of 1.95 ms for the
        closed form, and 72.5 % with a median of 200 ms for KDL (MoveIt, 15 s timeout). This
        notebook runs the same protocol through `wbik.study` on 200 poses with a few methods. It
        shows the pipeline's figures and sets the summary beside the thesis's numbers. The full
        runs are `wbik study` (1,000 poses, every method) and
        `wbik study comparisons/golem3_thesis.yaml` (10,000).
        """),
        code("""
        from pathlib import Path

        import numpy as np
        from IPython.display import Image, Markdown, display

        from wbik.study import load_study, run_study
        from wbik.study.report import case_rows
        from wbik.study.statistics import summarize, thesis_metrics
        """, ROOT_FINDER, """
        METHODS = ["analytic", "analytic_per_pose", "kdl", "kdl_restarts", "trac_ik", "bounded_lm"]
        study = load_study(ROOT / "comparisons" / "default.yaml").with_overrides(
            poses=200, methods=METHODS, chunk_size=50, name="notebook_small")
        case = study.cases[0]
        print(study.description.strip())
        print(f"{study.poses_of(case)} poses, seed {study.seed}, "
              f"default budget {study.timeout_s * 1e3:g} ms, FK check {study.tolerances}")
        for method in study.methods:
            print(f"  {method.label:<18} {study.timeout_of(method) * 1e3:6.1f} ms  {method.note}")
        """),
        md("""
        ## Run

        The run is chunked and resumable. Its results, figures and report go to
        `tests/artifacts/notebooks/study_small/` (git-ignored). It runs in this process (`jobs=1`),
        which takes about 10 s.
        """),
        code("""
        output = run_study(study, ARTIFACTS / "study_small", jobs=1, fresh=True, progress=False)
        rows_by_method, not_applicable = case_rows(study, case, output)
        assert set(rows_by_method) == set(METHODS), not_applicable
        print(sorted(path.name for path in output.iterdir()))
        """),
        md("""
        ## Summary beside the thesis

        Every method's answers pass the same FK check (1e-6 m, 1e-6 rad). The thesis's numbers
        are in the last two columns. The closed form has no unsolved poses (the thesis lost about
        6 % to rounding near singularities). The KDL rate depends on the budget: one attempt in
        5 ms versus restarts for 0.1 s, where MoveIt's KDL had 15 s. The times are the solver call
        alone on this machine, while the thesis timed ROS service calls in 2017.
        """),
        code("""
        def number(value, width, digits):
            missing = value is None or not np.isfinite(value)
            return f"{'-':>{width}}" if missing else f"{value:{width}.{digits}f}"

        reference = case.thesis["reference"]
        print(f"{'method':<18} {'solved %':>8} {'median ms':>10} {'no-solution ms':>15} "
              f"{'thesis %':>9} {'thesis ms':>10}")
        for label, rows in rows_by_method.items():
            ours = thesis_metrics(summarize(rows))
            theirs = reference.get(label, {})
            print(f"{label:<18} {number(ours['percent_solved'], 8, 1)} "
                  f"{number(ours['time_median_ms'], 10, 3)} {number(ours['time_mean_unsolved_ms'], 15, 3)} "
                  f"{number(theirs.get('percent_solved'), 9, 1)} "
                  f"{number(theirs.get('time_median_ms'), 10, 2)}")
            solved = rows["success"].astype(bool)
            for axis in ("x", "y", "z"):  # the shared FK check holds on every solved pose
                assert np.all(np.abs(rows[f"err_{axis}"][solved]) <= 1e-6)
        # the thesis's figures as the study file quotes them (golem3.md): 94 % / 72.5 %, 1.95 ms / 200 ms
        assert (reference["analytic"]["percent_solved"], reference["kdl"]["percent_solved"]) == (94.0, 72.5)
        medians = (reference["analytic_per_pose"]["time_median_ms"], reference["kdl"]["time_median_ms"])
        assert medians == (1.95, 200.0)
        analytic = thesis_metrics(summarize(rows_by_method["analytic"]))
        assert analytic["percent_solved"] >= 94.0  # at least the thesis's rate: the clamp keeps the lost 6 %
        """),
        md("The report's own table beside the thesis, with the Mann-Whitney tests (from `report.md`):"),
        code("""
        report = (output / "report.md").read_text()
        section = report[report.index("### Beside the thesis"):]
        display(Markdown(section))
        """),
        md("""
        ## Figures

        The pipeline writes these figures: solved fraction per method, per-axis errors of the
        solved poses (x, y, z and the thesis's yaw, pitch, roll), and time per call.
        """),
        code("""
        figures = output / case.name / "figures"
        for name in ("solved", "errors", "time"):
            display(Image(filename=str(figures / f"{name}.png"), width=800))
        """),
    ]


# --------------------------------------------------------------------------------------------------
def bioloid() -> list[tuple[str, str]]:
    return [
        md("""
        # 3. Bioloid: balance constraints, one foot lifted, the step forward

        The Bioloid humanoid (seed 003) is modelled as 18 servos on a floating base. The thesis
        balanced it only by a lateral hip shift. Here balance is a hard constraint of the
        whole-body QP: the soles on the ground are contacts, and the centre of mass (CoM) must
        project at least 5 mm inside the support polygon. The scenario `tasks/bioloid_balance.yaml`
        shifts the CoM over the right foot and lifts the left foot 40 mm. Then the thesis's step
        forward runs as whole-body IK, one QP per sample. Every answer is checked here again with
        hand geometry (sole rectangles, a convex hull from scipy) instead of wbik's polygon code.
        """),
        code("""
        from pathlib import Path

        import matplotlib.pyplot as plt
        import numpy as np
        from scipy.spatial import ConvexHull

        import wbik
        from wbik.scenarios import format_report, run_scenario
        from wbik.viz import Viewer
        """, ROOT_FINDER, """

        robot = wbik.load("bioloid")
        SOLE = robot.info["sole_corners"]          # 4 corners per sole, in the sole frame (m)
        HALF_LENGTH, HALF_WIDTH = np.abs(SOLE["r_sole"][:, :2]).max(axis=0)
        print("chains:", list(robot.chains), "| nq =", robot.model.nq, "(free flyer 7 + 18 joints)")
        print(f"sole {2 * HALF_LENGTH * 1e3:.0f} x {2 * HALF_WIDTH * 1e3:.0f} mm")


        def corners_world(q, sole):
            placement = robot.frame_placement(q, sole)
            return SOLE[sole] @ placement.rotation.T + placement.translation


        def hull_margin(q, soles):
            \"\"\"Signed distance (m) of the CoM ground point to the edge of the soles' convex hull.\"\"\"
            hull = ConvexHull(np.vstack([corners_world(q, sole)[:, :2] for sole in soles]))
            com_xy = robot.center_of_mass(q)[:2]
            return float(np.min(-(hull.equations[:, :2] @ com_xy + hull.equations[:, 2])))


        def draw_feet(ax, q, soles_down, title):
            for sole in ("r_sole", "l_sole"):
                corners = corners_world(q, sole)
                style = "-" if sole in soles_down else ":"
                ax.fill(*corners[:, :2].T * 1e3, alpha=0.15 if sole in soles_down else 0.0, color="tab:green")
                ax.plot(*np.vstack([corners, corners[:1]])[:, :2].T * 1e3, style, color="tab:green")
            hull = ConvexHull(np.vstack([corners_world(q, sole)[:, :2] for sole in soles_down]))
            loop = np.append(hull.vertices, hull.vertices[0])
            ax.plot(*hull.points[loop].T * 1e3, "k--", lw=0.8)
            com = robot.center_of_mass(q)
            ax.plot(com[0] * 1e3, com[1] * 1e3, "o", color="tab:purple", label="CoM (ground projection)")
            ax.set(aspect="equal", xlabel="x (mm)", ylabel="y (mm)", title=title)
        """),
        md("""
        ## The balance scenario: shift, then lift

        `run_scenario` solves each phase from the previous one. Phase 1 keeps both soles fixed
        and moves the CoM over the right foot. Phase 2 holds the right sole, lifts the left sole
        40 mm, and keeps the CoM 5 mm inside the right sole. The report's checks are wbik's own;
        the asserts below redo them by hand. For a CoM inside an axis-aligned rectangle, the
        margin is min(half length - |x|, half width - |y|) in the sole frame.
        """),
        code("""
        report = run_scenario(ROOT / "tasks" / "bioloid_balance.yaml")
        print(format_report(report))
        assert report["passed"]
        start = robot.nominal.copy()
        shifted, lifted = (np.array(phase["q"]) for phase in report["phases"])

        for q in (shifted, lifted):  # the right sole never moves
            assert np.allclose(corners_world(q, "r_sole"), corners_world(start, "r_sole"), atol=1e-6)
        assert np.allclose(corners_world(shifted, "l_sole"), corners_world(start, "l_sole"), atol=1e-6)
        lift = corners_world(lifted, "l_sole") - corners_world(start, "l_sole")
        assert np.allclose(lift, [0.0, 0.0, 0.04], atol=1e-6)  # the left sole 40 mm up, still flat

        r_sole = robot.frame_placement(lifted, "r_sole")
        com_in_sole = r_sole.actInv(robot.center_of_mass(lifted))
        margin_by_hand = min(HALF_LENGTH - abs(com_in_sole[0]), HALF_WIDTH - abs(com_in_sole[1]))
        print(f"CoM margin in the right sole, by hand: {margin_by_hand * 1e3:.3f} mm")
        assert margin_by_hand >= 0.005 - 1e-9
        """),
        code("""
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), sharey=True)
        draw_feet(axes[0], start, ("r_sole", "l_sole"), "standing")
        draw_feet(axes[1], shifted, ("r_sole", "l_sole"), "CoM shifted over the right foot")
        draw_feet(axes[2], lifted, ("r_sole",), "left foot lifted 40 mm (dotted)")
        axes[0].legend(fontsize=8, loc="lower left")
        fig.tight_layout()
        """),
        md("""
        The robot on one foot. The support polygon is drawn on the ground, green when the CoM
        projects inside; the purple ball is the CoM with its plumb line.
        """),
        code("""
        viewer = Viewer(robot)
        support = viewer.show_com_and_polygon(lifted, feet=["r_sole"])
        print(f"inside: {support.inside}, margin {support.margin * 1e3:.3f} mm")
        assert support.inside and abs(support.margin - margin_by_hand) < 1e-9
        viewer
        """),
        md("""
        ## The step forward

        The thesis's step has five phases: shift the hips over the right foot, lift the left foot,
        lower it ahead, move the hips over it, and bring the right foot beside it. Each phase
        has 5 divisions, and the gait numbers come from the robot's code (bioloid.md 4.4). Every
        sample is one whole-body QP with the soles on the ground as contacts, the swing sole on
        its path, and the CoM 5 mm inside the polygon of the soles on the ground. The asserts
        below recompute that margin with scipy's convex hull. They also check the code's gait:
        a 40 mm foot clearance (zd - zu) and a 30 mm step (xm - xf).
        """),
        code("""
        from wbik.bioloid.gait import GaitParameters
        from wbik.bioloid.step_wholebody import step_forward_wholebody

        step = step_forward_wholebody(robot, margin=0.005)
        motion = step.motion
        for key, value in step.summary().items():
            print(f"  {key}: {value:.4g}" if isinstance(value, float) else f"  {key}: {value}")
        assert step.passed

        margins = np.array([hull_margin(q, motion.support[k]) for k, q in enumerate(motion.q)])
        left = np.array([robot.frame_placement(q, "l_sole").translation for q in motion.q])
        right = np.array([robot.frame_placement(q, "r_sole").translation for q in motion.q])
        com = np.array([robot.center_of_mass(q) for q in motion.q])
        print(f"smallest CoM margin by hand: {margins.min() * 1e3:.3f} mm")
        assert margins.min() >= 0.005 - 1e-6
        gait = GaitParameters()
        assert np.isclose(left[:, 2].max(), 0.040, atol=1e-6) and np.isclose(gait.lift_height, 0.040)
        assert np.allclose(left[-1] - left[0], [0.030, 0.0, 0.0], atol=1e-6)
        assert np.allclose(right[-1] - right[0], [0.030, 0.0, 0.0], atol=1e-6)
        """),
        code("""
        fig = plt.figure(figsize=(12, 4))
        ax = fig.add_subplot(1, 2, 1)
        draw_feet(ax, motion.q[-1], ("r_sole", "l_sole"), "CoM path over the feet (start: dotted)")
        for sole in ("r_sole", "l_sole"):
            corners = corners_world(motion.q[0], sole)
            ax.plot(*np.vstack([corners, corners[:1]])[:, :2].T * 1e3, ":", color="gray")
        ax.plot(com[:, 0] * 1e3, com[:, 1] * 1e3, ".-", color="tab:purple", lw=1)
        ax = fig.add_subplot(1, 2, 2)
        samples = np.arange(len(motion.q))
        ax.plot(samples, left[:, 2] * 1e3, label="left sole z (mm)")
        ax.plot(samples, left[:, 0] * 1e3, label="left sole x (mm)")
        ax.plot(samples, right[:, 0] * 1e3, label="right sole x (mm)")
        ax.plot(samples, margins * 1e3, "k.-", lw=0.8, label="CoM margin (mm)")
        ax.axhline(5, color="k", ls="--", lw=0.6)
        for end in motion.phase_end_samples():
            ax.axvline(end, color="gray", lw=0.5)
        ax.set(xlabel="sample (phase ends in grey)", title="feet and balance margin along the step")
        ax.legend(fontsize=8)
        fig.tight_layout()
        """),
        md("The step as an animation (0.1 s per sample), tracing the left sole."),
        code("""
        viewer = Viewer(robot)
        viewer.animate(0.1 * np.arange(len(motion.q)), motion.q, trace_frame="l_sole")
        viewer.show_com_and_polygon(motion.q[-1])
        viewer
        """),
    ]


# --------------------------------------------------------------------------------------------------
NOTEBOOK_CELLS = {
    "01_quickstart.ipynb": quickstart,
    "02_thesis_study.ipynb": thesis_study,
    "03_bioloid_balance.ipynb": bioloid,
    "04_pincher.ipynb": pincher,
    "05_newton_path.ipynb": newton_path,
}


def build(name: str, cells: list[tuple[str, str]]) -> nbformat.NotebookNode:
    stem = name.split("_")[0]
    notebook = new_notebook(metadata={
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
    })
    for index, (kind, source) in enumerate(cells):
        cell = new_markdown_cell(source) if kind == "markdown" else new_code_cell(source)
        cell["id"] = f"nb{stem}-{index:02d}"
        notebook.cells.append(cell)
    nbformat.validate(notebook)
    return notebook


def build_all() -> dict[str, nbformat.NotebookNode]:
    return {name: build(name, make()) for name, make in NOTEBOOK_CELLS.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only compare with the committed notebooks")
    args = parser.parse_args(argv)
    NOTEBOOKS.mkdir(exist_ok=True)
    stale = []
    for name, notebook in build_all().items():
        path = NOTEBOOKS / name
        text = nbformat.writes(notebook) + "\n"
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(name)
        else:
            path.write_text(text, encoding="utf-8")
            print("wrote", path.relative_to(NOTEBOOKS.parent))
    if stale:
        print("not as generated:", ", ".join(stale), "- run scripts/make_notebooks.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
