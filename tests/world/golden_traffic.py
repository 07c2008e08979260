"""Golden outcomes of the traffic rule, recorded from its first, loop-until-stable version.

``python -m tests.world.golden_traffic`` rewrites ``tests/world/traffic_golden.npz``; it was
run once, before the rule was vectorised, so that the vectorised rule is held to the same grants.
"""

from pathlib import Path

import numpy as np

from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import resolve_layout
from warehouse_phys.world.traffic import resolve_moves

PATH = Path(__file__).with_name("traffic_golden.npz")
#: The most robots in a recorded case; shorter cases are padded with -1.
MAX_CASE_ROBOTS = 24
FLOORS = {
    "4x5": lambda: WarehouseGrid(4, 5),
    "aisles": lambda: resolve_layout("aisles"),
    "6x6 with shelves": lambda: WarehouseGrid.from_layout(
        ["S.....", ".#..#.", "......", "..##..", ".#....", "......"]
    ),
    "2x8 corridor": lambda: WarehouseGrid.from_layout(["S.......", "########"]),
}
CASES_PER_FLOOR = 600


def cases(floor: str, seed: int):
    """Random placements (sparse to full), actions 0..4, parked masks and corner settings."""
    grid = FLOORS[floor]()
    free = np.array(sorted(grid.reachable), dtype=np.int64)
    rng = np.random.default_rng(seed)
    for _ in range(CASES_PER_FLOOR):
        n = int(rng.integers(2, min(len(free), MAX_CASE_ROBOTS) + 1))
        cells = free[rng.choice(len(free), size=n, replace=False)]
        actions = rng.integers(5, size=n)
        parked = rng.random(n) < rng.choice([0.0, 0.2])
        corner = bool(rng.integers(2))
        yield grid, cells, actions, parked, corner


def record() -> dict[str, np.ndarray]:
    rows = {key: [] for key in ("floor", "n", "cells", "actions", "parked", "corner", "ends",
                                "refused")}  # fmt: skip
    for f, floor in enumerate(FLOORS):
        for grid, cells, actions, parked, corner in cases(floor, seed=f):
            ends, refused = resolve_moves(grid, cells, actions, parked, corner_follows=corner)
            n = len(cells)
            pad = MAX_CASE_ROBOTS - n
            rows["floor"].append(f)
            rows["n"].append(n)
            rows["cells"].append(np.pad(cells, ((0, pad), (0, 0)), constant_values=-1))
            rows["actions"].append(np.pad(actions, (0, pad), constant_values=-1))
            rows["parked"].append(np.pad(parked, (0, pad)))
            rows["corner"].append(corner)
            rows["ends"].append(np.pad(np.asarray(ends), ((0, pad), (0, 0)), constant_values=-1))
            rows["refused"].append(np.pad(np.asarray(refused, dtype=bool), (0, pad)))
    return {key: np.array(value) for key, value in rows.items()}


if __name__ == "__main__":
    np.savez_compressed(PATH, **record())
    print(f"wrote {PATH}")
