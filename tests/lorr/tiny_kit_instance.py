"""A tiny 2026 instance of our own (no shared data), the one the golden start-kit output
file ``data/kit_tiny_output.json`` was run on (``python -m tests.lorr.tiny_kit_instance
DIR`` writes it; the golden file is the kit 3.1.0's output of 90 ticks of it with the
entry's three components)."""

import sys

from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.lorr.generator import make_instance
from warehouse_phys.lorr.instances import LorrInstance, write_instance
from warehouse_phys.world.grid import WarehouseGrid

LAYOUT = (
    "..............",
    "..##.####.##..",
    "..............",
    "..##.####.##..",
    "..............",
    "..............",
)
TICKS = 90


def tiny_instance() -> LorrInstance:
    delays = DelayConfig(seed=5, min_delay=1, max_delay=4, event_model="bernoulli",
                         p_delay=0.05, duration_model="uniform")  # fmt: skip
    return make_instance(WarehouseGrid.from_layout(LAYOUT), 8, 60, seed=3, name="tiny",
                         delay=delays)  # fmt: skip


if __name__ == "__main__":
    print(write_instance(tiny_instance(), f"{sys.argv[1]}/tiny.json"))
