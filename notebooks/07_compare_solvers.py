# %% [markdown]
# # 7. Compare solvers on an arm you name
#
# Name any robot example-robot-data ships (or a URDF path) and a chain by its base and tip frames; this
# notebook draws reachable targets on that chain (forward kinematics of random joints inside the limits)
# and solves each with every method that applies, from the chain's nominal configuration. It shows, per
# method, the share solved under the shared FK check (1e-6 m, 1e-6 rad), the time of each call, the
# errors, and for the closed forms how many distinct branches reach a target. Change the first cell and
# run it again.

# %%
ROBOT = "example-robot-data:panda"          # a built-in name, example-robot-data:NAME or a URDF path
BASE, TIP = "panda_link0", "panda_link8"     # the chain: every joint between these two frames
POSES = 40
METHODS = ("analytic", "eaik", "ik_geo", "bounded_lm", "trac_ik", "kdl", "qp", "placo", "pink", "mink")

# %%
import matplotlib.pyplot as plt
import numpy as np

import wbik
from wbik.errors import MissingDependencyError, UnsupportedError

robot = wbik.load(ROBOT)
chain = robot.chain_between(BASE, TIP)
print(chain)
rng = np.random.default_rng(7)
targets = [chain.fk(q) for q in chain.random(rng, POSES)]

# %% [markdown]
# ## Every method on the same targets
#
# A method that cannot take this chain says why (a closed form the chain lacks, a library not
# installed); the others solve every target. `time_s` is one call's own latency.

# %%
results, refusals = {}, {}
for method in METHODS:
    try:
        solver = wbik.solver(method, robot, chain=chain.name)
        results[method] = [solver.solve(target) for target in targets]
    except (UnsupportedError, MissingDependencyError) as refused:
        refusals[method] = str(refused)

print(f"{'method':12s} {'solved':>8s} {'median ms':>10s} {'p95 ms':>8s} {'worst error, solved (m)':>24s}")
for method, answers in results.items():
    solved = [a for a in answers if a.success]
    times = np.array([a.time_s for a in answers]) * 1e3
    worst = max((a.position_error for a in solved), default=float("nan"))
    print(f"{method:12s} {len(solved):4d}/{POSES:<3d} {np.median(times):10.3f} "
          f"{np.percentile(times, 95):8.3f} {worst:24.2e}")
for method, why in refusals.items():
    print(f"{method:12s} not applicable: {why[:110]}")
assert "bounded_lm" in results and sum(a.success for a in results["bounded_lm"]) >= 0.9 * POSES

# %% [markdown]
# ## Time per call and share solved

# %%
figure, (left, right) = plt.subplots(1, 2, figsize=(11, 3.6))
names = list(results)
left.boxplot([[a.time_s * 1e3 for a in results[m]] for m in names], tick_labels=names, showfliers=False)
left.set_yscale("log")
left.set_ylabel("time per call (ms)")
left.tick_params(axis="x", rotation=45)
right.bar(names, [100 * np.mean([a.success for a in results[m]]) for m in names])
right.set_ylabel("% solved")
right.tick_params(axis="x", rotation=45)
figure.tight_layout()

# %% [markdown]
# ## How many ways to reach a target
#
# A closed form gives every branch inside the limits (`solve_all`); on a 7-joint arm the count is that
# of the branches it found with the held joint at its value.

# %%
if "analytic" in results:
    analytic = wbik.solver("analytic", robot, chain=chain.name)
    counts = [len(analytic.solve_all(target)) for target in targets]
    print("analytic family:", analytic.family, "- distinct branches per target:", np.bincount(counts))
    assert all(a.q is None or a.success for a in results["analytic"])
