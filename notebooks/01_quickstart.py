# %% [markdown]
# # 1. Quickstart: a robot, forward kinematics, three IK methods, a view
#
# This notebook loads the Golem-III upper body (the thesis's DH table, seed 000) and computes
# forward kinematics, checked here against the thesis's closed-form equations. It then solves
# one pose with three methods (the closed form, TRAC-IK and our bounded Levenberg-Marquardt)
# and compares their answers under the shared FK check. Last, it draws the robot with the
# target in an inline 3-D view.

# %%
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


# %% [markdown]
# ## Forward kinematics
#
# `chain.fk(q)` gives the tip pose in the chain's base frame (a `pin.SE3`). The thesis writes
# the gripper position and orientation in closed form (golem3.md: eq. 3.3-3.9 with two
# misprints corrected, R = Rz(gamma) Ry(beta) Rx(alpha)); the cell below types those
# equations in and asserts that both agree.

# %%
def thesis_fk(t):
    """Thesis eq. 3.3-3.9 (golem3.md): gripper position (m) and rotation of the right arm."""
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
print("rotation:\n", pose.rotation.round(4))
assert np.allclose(pose.translation, position, atol=1e-12)
assert np.allclose(pose.rotation, rotation, atol=1e-12)

# %% [markdown]
# ## Inverse kinematics with three methods
#
# The target is the FK of random joints inside the limits, so it has a solution. Every
# method returns the same `IKResult`, and `success` comes from one FK check shared by all
# methods (1e-6 m and 1e-6 rad). The closed form returns the branch nearest to `q0`.
# The numerical methods may settle on another branch: their joints can differ and still
# reach the same pose.

# %%
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

# %% [markdown]
# How far apart are the answers in joint space? The closed form also lists every branch
# (`solve_all`); each of them reaches the target.

# %%
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

# %%
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

# %% [markdown]
# A position-only target (a 3-vector) leaves the orientation free. Bad input raises a typed
# `wbik` error that says what to fix; an unreachable target returns `success=False` with a
# reason.

# %%
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

# %% [markdown]
# ## View
#
# `wbik.viz.Viewer` records a meshcat scene without a server, and in a notebook it displays
# itself inline as a self-contained page. The green triad is the target; the blue triad is
# the pose the closed form's answer reaches.

# %%
from wbik.viz import Viewer

viewer = Viewer(robot)
viewer.show_ik_result(results["analytic"], target, "right_arm")
viewer
