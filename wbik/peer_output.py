"""What a compiled peer library prints, kept off the user's terminal: its C/C++ code writes to the process's
file descriptors 1 and 2, beneath Python's ``sys.stdout``, so :func:`captured_output` swaps the descriptors
themselves for a temporary file while the call runs and hands the text back (logged at DEBUG on the
``wbik.peers`` logger, or put into an error's message by the caller)."""

from __future__ import annotations

import ctypes
import logging
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

LOGGER = logging.getLogger("wbik.peers")
_LOCK = threading.Lock()  # the descriptors are the process's: one capture at a time
_LIBC = ctypes.CDLL(None)  # fflush(NULL): C stdio's buffers (C++'s std::cout writes through them)


@dataclass
class CapturedOutput:
    """The text a peer printed during a :func:`captured_output` block (filled when the block ends)."""

    library: str
    text: str = ""

    def reason(self) -> str:
        """The printed text as one line for an error message ("" when nothing was printed)."""
        line = " ".join(self.text.split())
        return f" ({self.library} printed: {line!r})" if line else ""


@contextmanager
def captured_output(library: str) -> Iterator[CapturedOutput]:
    """Run the block with file descriptors 1 and 2 redirected to a temporary file; its text is logged and
    left in the yielded :class:`CapturedOutput`. Python's own streams are flushed first so nothing of ours
    is caught, C's stdio buffers last so nothing of the peer's escapes later."""
    captured = CapturedOutput(library)
    with _LOCK, tempfile.TemporaryFile(mode="w+b") as sink:
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        saved = [os.dup(descriptor) for descriptor in (1, 2)]
        try:
            for descriptor in (1, 2):
                os.dup2(sink.fileno(), descriptor)
            yield captured
        finally:
            _LIBC.fflush(None)
            for descriptor, original in zip((1, 2), saved, strict=True):
                os.dup2(original, descriptor)
                os.close(original)
            sink.seek(0)
            captured.text = sink.read().decode("utf-8", "replace")
            if captured.text.strip():
                LOGGER.debug("%s printed: %s", library, captured.text.strip())
