"""Resident memory of the test process, to show that something repeated holds no more."""

import gc
import os
from collections.abc import Callable

#: Whether this system shows a process's resident memory (Linux's /proc).
CAN_MEASURE = os.path.exists("/proc/self/statm")


def resident_bytes() -> int:
    """The process's resident memory now [bytes]."""
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def growth_per_reset(reset: Callable[[int], object], resets: int) -> float:
    """Resident memory gained per call of ``reset`` [bytes], after a warm-up."""
    for seed in range(1000):  # the allocator settles first
        reset(seed)
    gc.collect()
    before = resident_bytes()
    for seed in range(resets):
        reset(seed)
    gc.collect()
    return (resident_bytes() - before) / resets
