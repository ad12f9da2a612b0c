"""Packaging hook (everything else is in pyproject.toml): a built wheel carries the repository's
top-level data folders as package data under ``wbik/data/``: ``tasks/`` (with ``tasks/data/``), the
study files ``comparisons/*.yaml`` and the project's robot descriptions ``urdf/``; and it builds the
optional C extensions of
:mod:`wbik.kernels` (``wbik/kernels/_<name>.c``, one per kernel that module lists). Without a C
compiler the build goes on without them and their Python twins run.

The folders stay at the top level of the repository, where the README documents them;
:func:`wbik.data.data_dir` finds the packaged copy in an installed wheel and the top-level folder in
the source tree. Editable installs copy nothing (they read the top-level folders in place).
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
DATA = {
    # folder -> glob patterns of the files shipped (comparisons/reports/ is output, not shipped)
    "tasks": ("*.yaml", "*.yml", "*.json", "*.toml", "data/*.yaml"),
    "comparisons": ("*.yaml", "*.yml", "*.toml"),
    "urdf": ("*.urdf", "*.urdf.xml"),
}


class BuildPyWithData(build_py):
    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        for folder, patterns in DATA.items():
            target_root = Path(self.build_lib) / "wbik" / "data" / folder
            shutil.rmtree(target_root, ignore_errors=True)  # no stale copies of removed files
            for pattern in patterns:
                for source in sorted((ROOT / folder).glob(pattern)):
                    if source.is_file():
                        target = target_root / source.relative_to(ROOT / folder)
                        target.parent.mkdir(parents=True, exist_ok=True)
                        shutil.copy2(source, target)
            if not any(target_root.rglob("*")):
                raise RuntimeError(f"setup.py: no data files found in {ROOT / folder}")


COMPILE_ARGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fno-builtin-sin", "-fno-builtin-cos"]
"""The Python twins' bits: no fused multiply-add, no reassociation, and libm's own sin and cos (not a
merged sincos), as CPython's math module calls them (the C files say why)."""
KERNELS = ("pose", "ur_type", "stacked_planar", "eaik", "qp_rows", "lm_trial", "chain_fk")
"""wbik.kernels.KERNELS by name: each is wbik/kernels/_<name>.c (C++: .cpp), built as wbik.kernels._<name>."""
HEADERS = ["wbik/kernels/_buffers.h", "wbik/kernels/_pose_errors.h", "wbik/kernels/_closed_form.h",
           "wbik/kernels/_checked_errors.h"]
CXX_COMPILE_ARGS = ["-O2", "-g0", "-std=c++17", "-ffp-contract=off", "-fno-fast-math", "-DNDEBUG", "-w"]
"""The C++ kernel runs Pinocchio's header templates as the binding does (no fused multiply-add, no
reassociation; -w: Pinocchio's and Boost's headers warn of their own deprecations)."""


def pinocchio_headers() -> list[str] | None:
    """The include folders of Pinocchio, Boost and Eigen as their cmeel wheels install them
    (build-system.requires: libpinocchio, cmeel-eigen), or None where they are missing."""
    for folder in map(Path, sys.path):
        include = folder / "cmeel.prefix" / "include"
        if (include / "pinocchio" / "multibody" / "model.hpp").is_file() \
                and (include / "eigen3" / "Eigen" / "Core").is_file():
            return [str(include), str(include / "eigen3")]
    return None


def extension(name: str) -> Extension | None:
    source = Path("wbik/kernels") / f"_{name}.cpp"
    if not source.is_file():
        return Extension(f"wbik.kernels._{name}", [f"wbik/kernels/_{name}.c"], depends=HEADERS,
                         extra_compile_args=COMPILE_ARGS, libraries=["m"], optional=True)
    if os.environ.get("WBIK_BUILD_CXX", "1") == "0":
        print(f"setup.py: WBIK_BUILD_CXX=0: wbik.kernels._{name} is not built (its Python twin runs)",
              file=sys.stderr)
        return None
    include = pinocchio_headers()
    if include is None:
        print(f"setup.py: Pinocchio's or Eigen's headers not found; wbik.kernels._{name} is not built "
              "(its Python twin runs)", file=sys.stderr)
        return None
    return Extension(f"wbik.kernels._{name}", [source.as_posix()], depends=HEADERS, include_dirs=include,
                     language="c++", extra_compile_args=CXX_COMPILE_ARGS, optional=True)


EXTENSIONS = [built for built in map(extension, KERNELS) if built is not None]

# the C++ kernel takes about 12 s to compile: the C kernels build beside it, one per core
setup(cmdclass={"build_py": BuildPyWithData}, ext_modules=EXTENSIONS,
      options={"build_ext": {"parallel": os.cpu_count() or 1}})
