# %% [markdown]
# # 3. Bioloid: balance constraints, one foot lifted, the step forward
#
# The Bioloid humanoid (seed 003) is modelled as 18 servos on a floating base. The thesis
# balanced it only by a lateral hip shift. Here balance is a hard constraint of the
# whole-body QP: the soles on the ground are contacts, and the centre of mass (CoM) must
# project at least 5 mm inside the support polygon. The scenario `tasks/bioloid_balance.yaml`
# shifts the CoM over the right foot and lifts the left foot 40 mm. Then the thesis's step
# forward runs as whole-body IK, one QP per sample. Every answer is checked here again with
# hand geometry (sole rectangles, a convex hull from scipy) instead of wbik's polygon code.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.spatial import ConvexHull

import wbik
from wbik.scenarios import format_report, run_scenario
from wbik.viz import Viewer

ROOT = next(folder for folder in (Path.cwd(), *Path.cwd().parents) if (folder / "pyproject.toml").exists())
ARTIFACTS = ROOT / "tests" / "artifacts" / "notebooks"

robot = wbik.load("bioloid")
SOLE = robot.soles                         # 4 corners per sole, in the sole frame (m)
HALF_LENGTH, HALF_WIDTH = np.abs(SOLE["r_sole"][:, :2]).max(axis=0)
print("chains:", list(robot.chains), "| nq =", robot.model.nq, "(free flyer 7 + 18 joints)")
print(f"sole {2 * HALF_LENGTH * 1e3:.0f} x {2 * HALF_WIDTH * 1e3:.0f} mm")


def corners_world(q, sole):
    placement = robot.frame_placement(q, sole)
    return SOLE[sole] @ placement.rotation.T + placement.translation


def hull_margin(q, soles):
    """Signed distance (m) of the CoM ground point to the edge of the soles' convex hull."""
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


# %% [markdown]
# ## The balance scenario: shift, then lift
#
# `run_scenario` solves each phase from the previous one. Phase 1 keeps both soles fixed
# and moves the CoM over the right foot. Phase 2 holds the right sole, lifts the left sole
# 40 mm, and keeps the CoM 5 mm inside the right sole. The report's checks are wbik's own;
# the asserts below redo them by hand. For a CoM inside an axis-aligned rectangle, the
# margin is min(half length - |x|, half width - |y|) in the sole frame.

# %%
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

# %%
fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), sharey=True)
draw_feet(axes[0], start, ("r_sole", "l_sole"), "standing")
draw_feet(axes[1], shifted, ("r_sole", "l_sole"), "CoM shifted over the right foot")
draw_feet(axes[2], lifted, ("r_sole",), "left foot lifted 40 mm (dotted)")
axes[0].legend(fontsize=8, loc="lower left")
fig.tight_layout()

# %% [markdown]
# The robot on one foot. The support polygon is drawn on the ground, green when the CoM
# projects inside; the purple ball is the CoM with its plumb line.

# %%
viewer = Viewer(robot)
support = viewer.show_com_and_polygon(lifted, feet=["r_sole"])
print(f"inside: {support.inside}, margin {support.margin * 1e3:.3f} mm")
assert support.inside and abs(support.margin - margin_by_hand) < 1e-9
viewer

# %% [markdown]
# ## The step forward
#
# The thesis's step has five phases: shift the hips over the right foot, lift the left foot,
# lower it ahead, move the hips over it, and bring the right foot beside it. Each phase
# has 5 divisions, and the gait numbers come from the robot's code (bioloid.md 4.4). Every
# sample is one whole-body QP with the soles on the ground as contacts, the swing sole on
# its path, and the CoM 5 mm inside the polygon of the soles on the ground. The asserts
# below recompute that margin with scipy's convex hull. They also check the code's gait:
# a 40 mm foot clearance (zd - zu) and a 30 mm step (xm - xf).

# %%
from wbik.apps.bioloid.gait import GaitParameters
from wbik.apps.bioloid.step_wholebody import step_forward_wholebody

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

# %%
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

# %% [markdown]
# The step as an animation (0.1 s per sample), tracing the left sole.

# %%
viewer = Viewer(robot)
viewer.animate(0.1 * np.arange(len(motion.q)), motion.q, trace_frame="l_sole")
viewer.show_com_and_polygon(motion.q[-1])
viewer
