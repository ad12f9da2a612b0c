"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets.

Layered as IK-Geo: **subproblems** (:mod:`.subproblems`) -> **families**, each one module with its
closed form, its FK, its DH rows and its recogniser (:mod:`.ur_type`, :mod:`.yaw_planar`,
:mod:`.stacked_planar`; registered in :data:`.solver.FAMILIES`) -> **bindings**, a robot package's
closed-form classes or factories (``wbik/robot_packages/<robot>/closed_form.py``, given in the robot's
``closed_forms``). A chain without a binding gets a family from its structure (:mod:`.recognition`), else
EAIK's decomposition (:mod:`.eaik_family`), else, on a 7-joint chain, one joint held (:mod:`.redundancy`).

A closed form (:class:`.closed_form.ClosedForm`) maps B targets to K branches, ``Q`` (B, K, n) with a mask
``real``, and has its own vectorised FK. :class:`.solver.AnalyticSolver` wraps the branches into the limits
nearest q0, screens them with the form's FK and picks the nearest; a family may add a compiled kernel doing
the same in C (:mod:`.compiled`).
"""
