"""Marks and checks of the tests that compare a compiled kernel with its Python twin (the fixture they use,
``compiled_twins``, is in conftest.py)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

TWIN_TOLERANCE = 1e-12
"""rad: how far a closed-form kernel's joints may be from its twin's (the vectorised choice) where NumPy's
arctan2 and arccos are not libm's (NumPy's AVX-512 versions are one ulp off libm's on ~8 % of arguments;
measured kernel - twin on 2,000 random UR5 and Golem-III poses each: at most 3.4e-13 rad)."""
SINGULAR_TOLERANCE = 1e-7
"""rad: the same at a stretched elbow (sin of the elbow angle ~ 0), where the angle, atan2(sqrt(1 - c^2),
c), turns a one-ulp difference of c into ~1e-16 / |sin| (measured: up to 3.5e-10 rad for |sin| ~ 1e-6)."""


def compared_with_its_twin(kernel) -> list:
    """Skip where the kernel is not built (tests/test_compiled.py checks that it is wherever it can be),
    and pick the compiled twins even in a ``WBIK_PURE_PYTHON=1`` run (the comparison needs both)."""
    return [pytest.mark.skipif(kernel is None, reason="the C extension is not built here (no compiler or "
                               "Python headers): test_compiled checks that it is built wherever it can be"),
            pytest.mark.usefixtures("compiled_twins")]


def numpy_is_libm() -> bool:
    """Whether NumPy's arctan2 and arccos give libm's bits (math's) in this process: then a closed-form
    kernel and its twin agree bit for bit."""
    rng = np.random.default_rng(0)
    x, y, c = rng.uniform(-20.0, 20.0, 3000), rng.uniform(-20.0, 20.0, 3000), rng.uniform(-1.0, 1.0, 3000)
    return (np.array_equal(np.arctan2(x, y), [math.atan2(a, b) for a, b in zip(x, y, strict=True)])
            and np.array_equal(np.arccos(c), [math.acos(value) for value in c]))


TWIN_SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
import numpy as np, wbik
from compiled_twins import assert_twins_agree, numpy_is_libm
from wbik.targets import as_target
assert numpy_is_libm()
for robot, chain_name in {cases!r}:
    solver = wbik.solver("analytic", wbik.load(robot), chain=chain_name)
    assert solver.closed_form("pose").kernel is not None
    chain = solver.chain
    rng = np.random.default_rng(7)
    for q, q0 in zip(chain.random(rng, 300), chain.random(rng, 300)):
        assert_twins_agree(solver, as_target(chain.fk(q)), q0, bits=True)
print("same bits")
"""


def assert_same_bits_without_avx512(cases: list[tuple[str, str]]) -> None:
    """In a child Python whose NumPy uses none of its AVX-512 code (libm's arctan2 and arccos, what alone
    differs), the kernel's joints are its twin's bits on 300 random poses of each (robot, chain)."""
    from pathlib import Path

    from numpy._core._multiarray_umath import __cpu_dispatch__

    features = " ".join(feature for feature in __cpu_dispatch__ if feature.startswith("AVX512"))
    environment = {**os.environ, "NPY_DISABLE_CPU_FEATURES": features}
    environment.pop("WBIK_PURE_PYTHON", None)
    script = TWIN_SCRIPT.format(tests=str(Path(__file__).parent), cases=cases)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=environment)
    assert done.returncode == 0 and done.stdout.strip() == "same bits", done.stderr[-3000:]


def compiled_nearest(kernel, position, rotation, q0) -> tuple[np.ndarray | None, int]:
    """(the kernel's joints or None, its status: the real branches, or 0, -1, -2 as no_solution_reason)."""
    q = np.empty(len(q0))
    status = kernel.nearest_into(position, rotation, q0, q)
    return (q if status > 0 else None), status


def kernel_and_twin(solver, target, q0) -> tuple[tuple, tuple]:
    """(kernel's, twin's) (joints or None, status) for one target: the form's compiled choice and the
    vectorised choice it stands in for (status: the real branches, or the kernel's failure code)."""
    form = solver.closed_form("pose")
    position, rotation = target.position, target.rotation
    q, status = compiled_nearest(form.kernel, position, rotation, q0)
    choice = solver._choose(form, position[None], rotation[None], q0[None])
    if choice.found[0]:
        twin = (choice.q[0], int(choice.real.sum()))
    else:
        real, usable = bool(choice.real.any()), bool(choice.usable.any())
        twin = (None, 0 if not real else -2 if usable else -1)
    return (q, status), twin


def assert_twins_agree(solver, target, q0, bits: bool, tolerance: float = TWIN_TOLERANCE) -> float:
    """The kernel picks its twin's branch with the same status, the same joints (bit for bit where
    ``bits``, else within ``tolerance``); ``solve_all``'s branches alike. Returns the largest gap."""
    (q, status), (twin_q, twin_status) = kernel_and_twin(solver, target, q0)
    assert status == twin_status
    gap = 0.0
    if q is not None:
        gap = float(np.abs(q - twin_q).max())
        assert q.tobytes() == twin_q.tobytes() if bits else gap <= tolerance, (q, twin_q)
    form = solver.closed_form("pose")
    if not hasattr(form.kernel, "results"):  # a kernel of solve only
        return gap
    compiled = solver.solve_all(target)
    kernel, form.kernel = form.kernel, None
    try:
        vectorised = solver.solve_all(target)
    finally:
        form.kernel = kernel
    assert len(compiled) == len(vectorised)
    for mine, theirs in zip(compiled, vectorised, strict=True):
        assert mine.q.tobytes() == theirs.q.tobytes() if bits else \
            float(np.abs(mine.q - theirs.q).max()) <= tolerance
    return gap
