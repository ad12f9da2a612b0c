# %% [markdown]
# # 5. Newton-Raphson path of seed 001: visited points versus requested ones
#
# Seed 001 moves a 3-joint arm (l = 3, 2, 2) from P0 = (0, -2, 5) through P1 = (2, -3, 3),
# P2 = (0, -2, 2) and P3 = (0, -2, 5). Each segment is split into 10 sub-points, and each
# sub-point is solved by Newton-Raphson from the previous answer. The seed's printed
# "visited points" miss P2 and P3, even at eps = 1e-12. This notebook reproduces the
# seed's table of angles row by row and finds where the miss comes from. It then shows that
# wbik's `newton` with `follow_path` reaches every waypoint to 1e-9.

# %%
import matplotlib.pyplot as plt
import numpy as np

import wbik
from wbik.robot_packages.arm3r import model as arm3r
from wbik.solvers.newton import newton_step
from wbik.solvers.path import follow_path

robot = wbik.load("arm3r")                 # lengths (3, 2, 2), the seed's worked example
chain = robot.chain("arm")
START = arm3r.start_configuration()          # theta = (pi/2, pi/2, pi/2)
P0 = chain.fk(START).translation
WAYPOINTS = np.array([[2.0, -3.0, 3.0], [0.0, -2.0, 2.0], [0.0, -2.0, 5.0]])
print("P0 =", P0.round(12))
assert np.allclose(P0, [0.0, -2.0, 5.0], atol=1e-12)

# %%
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


# %% [markdown]
# ## The seed's loop, with wbik's kinematics
#
# For each segment and each sub-point k = 1..10, the loop iterates
# theta <- theta + J^-1 e until |e| <= eps. Here the step is `newton_step` (an LU solve)
# and J comes from the Pinocchio model, and every iterate is written as a row, as the seed
# wrote them. With eps = 0.1 this gives the seed's 31 rows to every printed digit.

# %%
def seed_loop(eps, substeps=10, max_iterations=100):
    """The seed's continuation: one row per Newton iterate (the start is row 1)."""
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

# %% [markdown]
# ## Where the waypoints went
#
# Rows 11, 21 and 31 (the 10th sub-point of each segment) reach P1, P2 and P3 within
# eps = 0.1, so the seed's angles do reach every waypoint. The printed "visited points" are
# FK of rows 1, 11, **20** and **29** instead. After the first segment the printout steps 9 rows
# instead of 10, an off-by-one in the printing and not in the solver. The seed's "worst
# error 0.5936 (z of P3)" is the distance to sub-point 8 of the last segment. At eps = 1e-12
# the printed (0.2, -2.1, 2.1) is again the 9th sub-point of segment 2, P1 + 0.9 (P2 - P1).
# The third printed point (z = 4.96) is no sub-point at all (those have z = 2.3, 2.6, ...,
# 5.0). The report is not detailed enough to reconstruct how that run printed it.

# %%
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

# %% [markdown]
# ## wbik's path: every waypoint to 1e-9
#
# `follow_path` splits each segment the same way and makes the last sub-point the waypoint
# itself. Here `newton` runs with a 1e-9 FK check and a 1 s budget per sub-point, and each row is
# a solved sub-point.

# %%
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

# %%
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

# %% [markdown]
# The seed did not guard against unreachable points, so its iteration never stopped on one.
# Here the path reports the waypoint it could not reach and carries on to the next.

# %%
unreachable = follow_path(solver, [WAYPOINTS[0], [0.0, 0.0, 12.0], WAYPOINTS[2]], START)
print("reached:", unreachable.reached)
print(unreachable.failures[-1])
assert unreachable.reached == [True, False, True]

# %% [markdown]
# The solved path as an animation (the yellow line is the tip's trace).

# %%
from wbik.viz import Viewer

viewer = Viewer(robot)
times = 0.1 * np.arange(len(path.joints))
viewer.animate(times, path.joints, chain="arm", trace_frame=chain.tip_frame)
viewer
