"""Registries of named things that modules declare (IK methods, case samplers, scenario kinds, ...): on
first use a :class:`DeclaredRegistry` reads the module-level tuple (``WHOLEBODY_CASES = (...)``) of the
modules its sources give (wbik's, through :func:`add_source`; user modules; its entry points). A module
that fails to import or declares none, or a name declared twice, is an error naming it, never skipped.
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Generic, Protocol, TypeVar

from wbik.errors import UnknownNameError, WbikError


class RegistryError(WbikError):
    """A name declared twice, or a listed module that declares no entries of the registry's type."""


class RegistryImportError(RegistryError):
    """A module listed in a registry that cannot be imported."""


class Named(Protocol):
    name: str


Entry = TypeVar("Entry", bound=Named)
Source = str | Callable[[], Iterable[ModuleType]]
"""A module's name, or a function giving the declaring modules."""

_SHIPPED: dict[str, list[Source]] = {}
_REGISTRIES: dict[str, DeclaredRegistry] = {}
_SHIPPED_LOCK = threading.Lock()


def add_source(what: str, source: Callable[[], Iterable[ModuleType]]) -> None:
    """Add ``source``, a function giving declaring modules, to the registry of ``what``s (now or later)."""
    with _SHIPPED_LOCK:
        _SHIPPED.setdefault(what, []).append(source)
        registry = _REGISTRIES.get(what)
    if registry is not None:
        registry._add_shipped(source)


def source_label(source: Source) -> str:
    """A source in words: the module's name, or the function's qualified name."""
    return source if isinstance(source, str) else f"{source.__module__}.{source.__qualname__}()"


class DeclaredRegistry(Generic[Entry]):
    """Entries of ``entry_type`` its sources' modules declare as ``attribute``; ``what`` names an entry,
    ``modules`` (the caller's list, kept) are the sources, ``listed_in`` where they are defined,
    ``unknown(name, known)`` the error for a name nobody declares, ``plugins`` an entry-point group."""

    def __init__(self, what: str, attribute: str, modules: list[str], listed_in: str, entry_type: type[Entry],
                 unknown: Callable[[str, list[str]], WbikError] | None = None,
                 error: type[RegistryError] = RegistryError,
                 import_error: type[RegistryImportError] = RegistryImportError, plugins: str | None = None):
        self.plugins = plugins
        modules.extend(name for name in plugin_modules(plugins) if name not in modules)
        with _SHIPPED_LOCK:
            modules.extend(source for source in _SHIPPED.get(what, ()) if source not in modules)
            _REGISTRIES[what] = self
        self.what, self.attribute, self.modules, self.listed_in = what, attribute, modules, listed_in
        self.entry_type, self.error, self.import_error = entry_type, error, import_error
        self.unknown = unknown or (lambda name, known: UnknownNameError(name, known,
                                                                        hint=f"(the registered {what}s)"))
        self._declared_by_default = frozenset(modules)  # what a fresh process imports
        self._entries: dict[str, Entry] = {}
        self._origins: dict[str, str] = {}
        self._sources: dict[str, Source] = {}
        self._loaded: set[str] = set()
        self._lock = threading.RLock()

    def _add_shipped(self, source: Source) -> None:
        with self._lock:
            if source not in self.modules:
                self.modules.append(source)
            self._declared_by_default |= {source}

    @contextmanager
    def isolated(self, modules: list[Source] | None = None) -> Iterator[DeclaredRegistry[Entry]]:
        """This registry emptied, listing ``modules`` (default: a copy of its list), for the time of the
        block (for tests and for trying a list of modules); what it held is back afterwards."""
        with self._lock:
            saved = dict(vars(self))
            self.modules = list(self.modules if modules is None else modules)
            self._declared_by_default = frozenset(self.modules)
            self._entries, self._origins, self._loaded, self._sources = {}, {}, set(), {}
        try:
            yield self
        finally:
            with self._lock:
                vars(self).update(saved)

    def entries(self) -> dict[str, Entry]:
        """Every entry by name (the listed modules imported on first use)."""
        with self._lock:
            for source in list(self.modules):
                self._load_once(source)
            return dict(self._entries)

    def declaring_modules(self) -> list[ModuleType]:
        """The modules the sources give, in order (imported now)."""
        return [module for source in list(self.modules) for module in
                ([importlib.import_module(source)] if isinstance(source, str) else source())]

    def descriptions(self) -> dict[str, str]:
        """Every entry's one-line ``description`` ("" for none), by name in alphabetical order."""
        return {name: getattr(entry, "description", "") for name, entry in sorted(self.entries().items())}

    def get(self, name: str) -> Entry:
        """The entry called ``name`` (the registry's ``unknown`` error, listing the names, if none)."""
        entries = self.entries()
        if not isinstance(name, str) or name not in entries:
            raise self.unknown(name if isinstance(name, str) else repr(name), sorted(entries))
        return entries[name]

    def added_at_run_time(self, name: str) -> Entry | None:
        """The entry ``name`` when user code added it (a fresh process does not have it), else None."""
        entries = self.entries()
        with self._lock:
            if name not in entries or self._sources.get(name) in self._declared_by_default:
                return None
            return entries[name]

    def register(self, entry: Entry, replace: bool = False) -> None:
        """Add ``entry`` from user code (``replace`` an entry of the same name only when asked)."""
        if not isinstance(entry, self.entry_type):
            raise self.error(f"a {self.what} is registered as a {self.entry_type.__name__}, got "
                                f"{type(entry).__name__}")
        self.entries()  # the declared entries first, so a clash is found now
        with self._lock:
            self._add(entry, "register()", replace)

    def register_module(self, module_name: str) -> None:
        """Add the entries the module ``module_name`` declares (imported now; an error adds nothing)."""
        self.entries()
        with self._lock:
            self._load_once(module_name)
            if module_name not in self.modules:
                self.modules.append(module_name)

    # -- loading -----------------------------------------------------------------------------------
    def _load_once(self, source: Source) -> None:
        if source in self._loaded:
            return
        try:
            modules = [importlib.import_module(source)] if isinstance(source, str) else list(source())
        except ImportError as exc:
            raise self.import_error(
                f"the {self.what}s of {source_label(source)} (listed in {self.listed_in}) cannot be "
                f"registered: importing it failed: {exc}. Install what it names (pip install -e . installs "
                f"wbik's own dependencies), or remove the module from that list") from exc
        for module in modules:
            self._load_module(module, source)
        self._loaded.add(source)

    def _load_module(self, module: ModuleType, source: Source) -> None:
        module_name = module.__name__
        declared = getattr(module, self.attribute, None)
        if not isinstance(declared, tuple | list) or not all(isinstance(item, self.entry_type)
                                                               for item in declared):
            raise self.error(f"{module_name} is listed in {self.listed_in} but has no {self.attribute} "
                             f"tuple of {self.entry_type.__name__}")
        names = [entry.name for entry in declared]
        if twice := sorted({name for name in names if names.count(name) > 1}):
            raise self.error(f"{module_name} declares the {self.what}(s) {', '.join(twice)} twice")
        for entry in declared:  # all or nothing: check every name before adding any
            self._check_new(entry, module_name)
        for entry in declared:
            self._add(entry, module_name)
            self._sources[entry.name] = source

    def _check_new(self, entry: Entry, where: str) -> None:
        known = self._entries.get(entry.name)
        if known is not None and known is not entry:
            raise self.error(f"{self.what} {entry.name!r} of {where} is already registered "
                                f"(by {self._origins[entry.name]})")

    def _add(self, entry: Entry, where: str, replace: bool = False) -> None:
        if not replace:
            self._check_new(entry, where)
        self._entries[entry.name] = entry
        self._origins[entry.name] = where
        self._sources.pop(entry.name, None)


def plugin_modules(group: str | None) -> list[str]:
    """The modules named by the entry points of ``group`` (none for None), sorted by entry name."""
    if group is None:
        return []
    from importlib import metadata  # on a registry's first use: kept out of import wbik

    found = sorted(metadata.entry_points(group=group), key=lambda entry: (entry.name, entry.value))
    return [entry.value.split(":")[0] for entry in found]

