"""The discipline of a control loop's ticks: Python's cyclic garbage collector does not run inside them.

A tick of the walk (pattern plus whole-body step) takes 0.1-0.4 ms; a collection of the older
generations, which Python starts whenever enough container objects were allocated, takes up to about a
millisecond of CPU and fell inside about one tick in 300 (``benchmarks/walking.py``). Real-time loops
do not let it: the collector is switched off for the loop (reference counting still frees everything
the ticks drop; only reference cycles wait) and its previous state is restored afterwards.
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
