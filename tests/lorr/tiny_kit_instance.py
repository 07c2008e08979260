"""A tiny 2026 instance of our own (no shared data), the one the golden start-kit output
file ``data/kit_tiny_output.json`` was run on (``python -m tests.lorr.tiny_kit_instance
DIR`` writes it; the golden file is the kit 3.1.0's output of 90 ticks of it with the
entry's three components), and :func:`station_instance`, the same floor with two stations
where the station cap binds."""

import dataclasses
import sys

import numpy as np

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


#: The two stations of :func:`station_instance`: the east end of the top row, the west
#: end of the bottom row.
STATIONS = (13, 5 * 14)


def station_instance() -> LorrInstance:
    """The tiny floor with 20 robots and tasks of two errands, each task's first at one of
    :data:`STATIONS` (alternately): more robots than two stations' caps
    (:data:`~warehouse_phys.lorr.station_cap.STATION_CAP` each), so the cap binds."""
    base = make_instance(WarehouseGrid.from_layout(LAYOUT), 20, 80, seed=3, name="stations")
    stops = base.task_stops.reshape(-1, 2).copy()
    stops[:, 0] = np.array(STATIONS)[np.arange(len(stops)) % 2]
    stops[stops[:, 1] == stops[:, 0], 1] = 3 * 14 + 4  # no errand where the last one was
    return dataclasses.replace(base, task_stops=stops.reshape(-1))


if __name__ == "__main__":
    print(write_instance(tiny_instance(), f"{sys.argv[1]}/tiny.json"))
