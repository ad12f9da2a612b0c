"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets.

The closed forms are layered as IK-Geo layers its solvers:

1. **subproblems** (:mod:`.subproblems`): planar 2R, clamped cosines, shared by every family;
2. **kinematic families**: :mod:`.ur_type` (UR-type 6R, axes 2-4 parallel), :mod:`.yaw_planar` (a
   base yaw carrying a planar arm: the 3R arm, the Pincher), :mod:`.stacked_planar` (a horizontal
   planar 3R carrying a vertical planar 2R and a roll: the Golem-III arm);
3. **one binding per robot**, in the robot's package (``wbik/robot_packages/<robot>/closed_form.py``):
   the robot's geometry and which family solves which chain. The Bioloid's is the exception: it keeps
   the thesis's own decomposition of the arm and the leg (equation by equation) on the shared
   subproblems.

A chain without a binding gets its family from its structure (:mod:`.recognition`: the joint axes at
q = 0 matched against every family, the parameters and the chain's frame and joint conventions read
off them, the form held to the model's FK), else EAIK's decomposition for full poses
(:mod:`.eaik_family`), else, on a 7-joint chain, one joint held at a value (:mod:`.redundancy`);
``AnalyticSolver.families`` names what solves each target kind.

The framework over them is :mod:`.closed_form` and :mod:`.solver`. A closed form is a :class:`ClosedForm`
registered for
(robot, chain, target kind). It maps a batch of B targets to K candidate branches per target, ``Q``
(B, K, n), with a mask ``real`` (B, K) of branches that exist (real square roots / cosines in [-1, 1],
with a small clamp tolerance), and provides its own vectorised FK. :class:`AnalyticSolver` wraps
revolute angles into the limits (nearest to q0), drops branches outside the limits or whose
closed-form FK misses the target by more than ``screen_tolerance`` (the *screen*), and picks the
branch nearest to q0; the reason of a failure comes from the same masks (no real branch / none
inside the limits / none reaches the target), nothing is computed twice.

Scalar fast path: a closed form may also enumerate the branches of one target in plain floats
(``branches_one``, ``fk_one``); ``solve`` and ``solve_all`` then avoid NumPy's per-call cost. The
choice is the same rule (:func:`nearest_branch`), and tests check that both paths agree.

The result goes through the shared check of :mod:`wbik.solvers.base` (``solve``, and ``solve_all`` on
the Python path) or its batched twin :func:`wbik.solvers.analytic.batch.evaluate_batch` (``solve_many``):
the same rule (clip, position and rotation error, tolerances), with the closed form's FK in place of
Pinocchio's, which :mod:`.model_agreement` holds to the model's when the form is built.

Compiled kernel: a family may provide one (``ClosedForm.kernel``; the UR-type family's is
:mod:`.ur_kernel`), the scalar path in C with the same bits, used by ``solve``, ``solve_many`` and
``solve_all`` (see their docstrings) unless ``WBIK_PURE_PYTHON=1`` (:mod:`wbik.kernels`).
"""

