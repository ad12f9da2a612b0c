"""A study run owns its output folder: ``fcntl.flock`` on ``<output>/.wbik-lock`` for the whole run (dropped
when the process dies); a second run into the folder raises :class:`FolderBusyError`."""

from __future__ import annotations

import fcntl
import os
import shutil
from pathlib import Path

from wbik.errors import WbikError

LOCK_NAME = ".wbik-lock"


class FolderBusyError(WbikError, RuntimeError):
    """Another run holds the output folder."""


class FolderLock:
    """Exclusive ownership of a study's output folder (a context manager)."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self._handle = None

    def __enter__(self) -> FolderLock:
        if self.folder.exists() and not self.folder.is_dir():
            raise WbikError(f"{self.folder} is a file; a study writes into a folder: pass another --output")
        self.folder.mkdir(parents=True, exist_ok=True)
        handle = open(self.folder / LOCK_NAME, "a+")  # noqa: SIM115 - held open for the lock's lifetime
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "another process"
            handle.close()
            raise FolderBusyError(
                f"{self.folder} is in use by another wbik study run ({holder}); wait for it to end, or "
                "pass another --output") from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()}")
        handle.flush()
        self._handle = handle
        remove_temporaries(self.folder)
        return self

    def __exit__(self, *exc_info) -> None:
        if self._handle is not None:
            self._handle.close()  # closing drops the lock
            self._handle = None

    def clear(self) -> None:
        """Delete everything in the folder but the lock file (only while holding the lock)."""
        if self._handle is None:
            raise WbikError("clear() needs the folder's lock")
        for entry in self.folder.iterdir():
            if entry.name == LOCK_NAME:
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()


def remove_temporaries(folder: Path) -> None:
    """Remove the ``.NAME.PID.tmp`` files under ``folder`` (left by killed writers)."""
    for path in Path(folder).rglob(".*.tmp"):
        if path.is_file():
            path.unlink(missing_ok=True)
