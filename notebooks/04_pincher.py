# %% [markdown]
# # 4. PhantomX Pincher: the seed's FK and IK examples, joint and linear moves
#
# This notebook covers the 4-DOF Pincher arm of seed 004 (DH model, tool frame `noa`,
# joints +-150 deg). It reproduces the seed's forward-kinematics check and its closed-form
# IK example, both asserted. It then runs the teleoperation's moves: a joint jog stopped
# at the limit, a straight TCP line in the reduced working plane (z = 137 mm, tool
# horizontal), and the automatic pick-and-place cycle, timed under velocity limits and
# plotted.

# %%
import math

import matplotlib.pyplot as plt
import numpy as np

import wbik
from wbik import motion
from wbik.apps.pincher import teleoperation as pincher
from wbik.robot_packages.pincher.closed_form import pose_from_position_pitch

robot = wbik.load("pincher")
chain = robot.chain("arm")
print(chain.joint_names, chain.base_frame, "->", chain.tip_frame)
print("limits (deg):", np.degrees(chain.lower).round(1), np.degrees(chain.upper).round(1))

# %% [markdown]
# ## The seed's FK check
#
# q = [15, 30, 45, 60] deg gives p = [213.5636, 57.2242, 187.9335] mm and ZYZ Euler angles
# [15, 135, -180] deg (pincher.md). -180 and 180 deg are the same angle.

# %%
pose = chain.fk(np.radians([15.0, 30.0, 45.0, 60.0]))
p_mm, R = pose.translation * 1000.0, pose.rotation
zyz_deg = np.degrees([math.atan2(R[1, 2], R[0, 2]), math.atan2(math.hypot(R[0, 2], R[1, 2]), R[2, 2]),
                      math.atan2(R[2, 1], -R[2, 0])])
print("p (mm):", p_mm.round(4))
print("R:\n", R.round(4))
print("ZYZ (deg):", zyz_deg.round(4))
np.testing.assert_allclose(p_mm, [213.5636, 57.2242, 187.9335], atol=1e-4)
SEED_R = [[0.6830, 0.2588, 0.6830], [0.1830, -0.9659, 0.1830], [0.7071, 0.0, -0.7071]]
np.testing.assert_allclose(R, SEED_R, atol=1e-4)
wrapped = (zyz_deg - np.array([15.0, 135.0, -180.0]) + 180.0) % 360.0 - 180.0
assert np.abs(wrapped).max() < 1e-6

# %% [markdown]
# ## The seed's IK example
#
# The seed's pose is [px, py, pz, theta] = [150, 200, 200] mm with a tool pitch of 60 deg.
# It gives q = [53.1301, 81.0504, 28.7724, -79.8228] deg. The seed's command line prints
# pz = 300, a typo: FK of that q is (150, 200, 200) mm. A 4-DOF arm cannot take every
# orientation, so the target is the full pose this position and pitch imply. The closed
# form finds both elbows, and the numerical methods reach the same pose.

# %%
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

# %% [markdown]
# ## Joint moves
#
# A jog moves one joint and leaves the others where they are, stopping at the +-150 deg
# limit. Asking joint 2 for +200 deg moves it to 150 deg. `motion.joint_path` interpolates
# between whole configurations.

# %%
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

# %% [markdown]
# ## A linear move in the reduced working plane
#
# In the seed's reduced working plane the arm stays parallel to the floor. Read precisely,
# the TCP stays at z = 137 mm with the tool horizontal and pointing away from the base.
# The reachable band is 149.4 mm <= r <= 305 mm within +-150 deg around the base. The
# line below is solved knot by knot with the closed form, and each knot is asserted to lie
# on the straight line at 137 mm.

# %%
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

# %% [markdown]
# ## The automatic cycle, timed
#
# The automatic mode is a fixed pick-and-place cycle of straight TCP segments with the tool
# pointing down. The seed gives no numbers for it, so the points are our choice. The joint
# path is timed with a quintic law under a 2 rad/s joint speed limit, and then sampled
# every 50 ms.

# %%
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

# %% [markdown]
# The timed cycle in the viewer; the yellow line is the TCP's trace.

# %%
from wbik.viz import Viewer

viewer = Viewer(robot)
viewer.play(trajectory)
viewer
