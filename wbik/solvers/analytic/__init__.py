"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets.

Layered as IK-Geo: subproblems (:mod:`.subproblems`) -> families, one module each with its closed form, FK,
DH rows and recogniser (:mod:`.ur_type`, :mod:`.yaw_planar`, :mod:`.stacked_planar`) -> a robot package's
bindings (its ``closed_forms``). A chain without a binding gets a family recognised from its structure
(:mod:`.recognition`), else EAIK's decomposition (:mod:`.eaik_family`), else on 7 joints one joint held
(:mod:`.redundancy`). A :class:`.closed_form.ClosedForm` maps B targets to branches Q (B, K, n) with a mask
``real`` and has its own FK; :class:`.solver.AnalyticSolver` wraps them into the limits nearest q0, screens
them with that FK and picks the nearest, in C where a family has a kernel (:mod:`.compiled`).
"""
