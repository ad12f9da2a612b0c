"""The optional libraries behind some methods (each peer an extra: ``pip install 'wbik[placo]'``,
``wbik[all]`` for all; orocos KDL's binding from Debian), named by a method's ``needs``, and the one message
a missing one gets (:meth:`OptionalDependency.error`), raised and reported by a study alike."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib.util import find_spec

from wbik.errors import MissingDependencyError


def extra(name: str) -> str:
    """The command that installs the package's extra ``name``."""
    return f"pip install 'wbik[{name}]' (in a clone, bash scripts/setup.sh installs every extra)"


@dataclass(frozen=True)
class OptionalDependency:
    """An optional library: what it is called (``needs``), the modules it provides and how to install it."""

    needs: str
    modules: tuple[str, ...]
    install: str

    def installed(self) -> bool:
        """Whether every module can be found (without importing it: listing methods stays quick)."""
        try:
            return all(find_spec(module) is not None for module in self.modules)
        except (ImportError, ValueError):  # a parent package missing, or a broken one
            return False

    def error(self, what: str, cause: BaseException | None = None) -> MissingDependencyError:
        """The error of ``what`` (e.g. "method 'placo'") without it; ``cause`` is the failed import."""
        found = "" if cause is None else f" ({cause})"
        return MissingDependencyError(f"{what} needs {self.needs}, which is not installed here{found}; "
                                      f"install it with: {self.install}")


def import_optional(library: OptionalDependency, what: str, module: str):
    """``module`` of an optional library, or MissingDependencyError saying ``what`` needs it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise library.error(what, exc) from None


PLACO_LIBRARY = OptionalDependency("PlaCo (0.10, which needs pin 3.8.0 exactly)", ("placo",), extra("placo"))
PINK_LIBRARY = OptionalDependency("Pink", ("pink",), extra("pink"))
MINK_LIBRARY = OptionalDependency("mink and MuJoCo", ("mink", "mujoco"), extra("mink"))
EAIK_LIBRARY = OptionalDependency("EAIK", ("eaik",), extra("eaik"))
IK_GEO_LIBRARY = OptionalDependency("ik-geo", ("ik_geo",), extra("ikgeo"))
TRAC_IK_LIBRARY = OptionalDependency("pytracik (TRAC-IK's Python binding)", ("pytracik",), extra("tracik"))
DASK_LIBRARY = OptionalDependency("dask.distributed", ("dask.distributed",), extra("dask"))
PYKDL_LIBRARY = OptionalDependency(
    "PyKDL (orocos KDL's Python binding, not on PyPI)", ("PyKDL",),
    "sudo apt-get install python3-pykdl, then bash scripts/setup.sh to expose it in the venv")
