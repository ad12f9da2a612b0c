# %% [markdown]
# # UR5 riveting (EuRoC Challenge 1, Task 2)
#
# The cell of `tasks/ur5_riveting.yaml`, two cycles of our QP planner (5-D insertion task,
# workpiece clearance constraint, time-optimal moves), checked and scored, then played in
# meshcat. The full 300 s comparison: `wbik run tasks/ur5_riveting.yaml`.

# %%
import meshcat.geometry as mg
import numpy as np
import yaml

from wbik.apps.riveting.cycle import simulate
from wbik.apps.riveting.report import Cell, run_config
from wbik.viz import Viewer

spec = yaml.safe_load(open("../tasks/ur5_riveting.yaml"))
cell = Cell(spec)
planner = cell.planner({"name": "ours", "planner": "ours"})
config = run_config(spec, max_cycles=2)
result = simulate(planner, cell.scene, cell.collision, cell.insertion, cell.q_home, config)
for cycle in result.cycles:
    if not cycle["success"]:
        print(cycle["hole"], cycle["face"], "not planned:", cycle["reason"])
        continue
    print(cycle["hole"], cycle["face"], cycle.get("route"), f"cycle {cycle['cycle_time_s']:.2f} s",
          f"lateral {cycle['lateral_error_m'] * 1e3:.4f} mm",
          f"pin clearance {cycle['tool_min_m'] * 1e3:.3f} mm")
result.summary()["score"]

# %%
viewer = Viewer(cell.robot)
box = np.eye(4)
box[:3, 3] = cell.scene.workpiece_center
grey = mg.MeshLambertMaterial(color=0x8899AA, opacity=0.6, transparent=True)
red = mg.MeshLambertMaterial(color=0xDD2222)
viewer.meshcat["cell/workpiece"].set_object(mg.Box(cell.scene.workpiece_size), grey)
viewer.meshcat["cell/workpiece"].set_transform(box)
for hole in cell.scene.holes:
    marker = np.eye(4)
    marker[:3, 3] = hole.position
    viewer.meshcat[f"cell/holes/{hole.name}"].set_object(mg.Sphere(0.004), red)
    viewer.meshcat[f"cell/holes/{hole.name}"].set_transform(marker)
times, rows = [], []
for start, move in result.timeline:
    local = np.arange(0.0, max(move.duration, 1e-3), 0.04)
    times += list(start + local)
    rows += list(move.evaluate(local))
keep = np.r_[True, np.diff(times) > 1e-6]
viewer.animate(np.array(times)[keep], np.array(rows)[keep], trace_frame="tcp")
viewer
