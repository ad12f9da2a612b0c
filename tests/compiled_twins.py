"""Marks of the tests that compare a compiled kernel with its Python twin (the fixture they use,
``compiled_twins``, is in conftest.py)."""

from __future__ import annotations

import pytest


def compared_with_its_twin(kernel) -> list:
    """Skip where the kernel is not built (tests/test_compiled.py checks that it is wherever it can be),
    and pick the compiled twins even in a ``WBIK_PURE_PYTHON=1`` run (the comparison needs both)."""
    return [pytest.mark.skipif(kernel is None, reason="the C extension is not built here (no compiler or "
                               "Python headers): test_compiled checks that it is built wherever it can be"),
            pytest.mark.usefixtures("compiled_twins")]
