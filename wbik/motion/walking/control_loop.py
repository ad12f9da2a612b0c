"""The discipline of a control loop's ticks: Python's cyclic garbage collector does not run inside them.

A collection of the older generations, which Python starts whenever enough container objects were
allocated, can take longer than a whole tick of the walk (pattern plus whole-body step), and some ticks
meet one (``benchmarks/walking.py`` measures both; the figures: docs/measurements.md, control_loop).
Real-time loops do not let it: the collector is switched off for the loop (reference counting still
frees everything the ticks drop; only reference cycles wait) and its previous state is restored
afterwards.
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
