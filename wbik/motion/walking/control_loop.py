"""A control loop's ticks run without Python's cyclic garbage collector: a collection of the older
generations can take longer than a whole tick (docs/measurements.md, control_loop); reference counting
still frees what the ticks drop.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def without_cyclic_gc() -> Iterator[None]:
    """Run the block with the cyclic garbage collector off; its previous state is restored after."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
