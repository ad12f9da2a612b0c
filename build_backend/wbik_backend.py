"""wbik's build backend: setuptools' own (``setuptools.build_meta``), which also asks for the C++ kernel's
header packages (Pinocchio's and Eigen's cmeel wheels) wherever that kernel is built: not with
``WBIK_BUILD_CXX=0`` nor without a C++ compiler, so such a machine builds wbik without fetching them."""

from __future__ import annotations

import os
import shutil

from setuptools import build_meta as setuptools_backend
from setuptools.build_meta import *  # noqa: F403 - every hook of setuptools' backend, as it is

CXX_HEADERS = ["libpinocchio==3.8.0", "cmeel-eigen==3.4.1"]
"""The C++ kernel's headers (wbik/kernels/_chain_fk.cpp; no library linked): the libpinocchio that the
lock's ``pin`` depends on, whose FK the kernel must reproduce bit for bit, and the Eigen its wheels use."""


def cxx_requirements() -> list[str]:
    """:data:`CXX_HEADERS` where setup.py builds the C++ kernel, else nothing."""
    wanted = os.environ.get("WBIK_BUILD_CXX", "1") != "0"
    return list(CXX_HEADERS) if wanted and (shutil.which("c++") or shutil.which("g++")) else []


def get_requires_for_build_wheel(config_settings=None) -> list[str]:
    return setuptools_backend.get_requires_for_build_wheel(config_settings) + cxx_requirements()


def get_requires_for_build_editable(config_settings=None) -> list[str]:
    return setuptools_backend.get_requires_for_build_editable(config_settings) + cxx_requirements()
