"""Floors made by rule, and the small benchmark maps the package ships, made by them.

Three generators give a floor as layout rows (``.`` floor, ``#`` shelf; see
:mod:`warehouse_phys.world.layouts`): :func:`warehouse`, Kiva-style warehouses (rows of
shelf blocks, aisles between; its defaults are the classic ``kiva-33-46.map`` cell for
cell), :func:`random_floor`, shelves scattered at random from a seed, and :func:`maze`,
corridors of a chosen width between walls, drawn from a seed.

:data:`MAPS` names the benchmark maps the package ships as MovingAI ``.map`` files (in
``map_files/``, package data; :func:`map_path` finds one), each what its generator writes
today (:func:`write_map`; a test holds every shipped file to it, so none can drift).
Every ``layout=`` and ``--layout`` takes their names: ``layout="kiva-33-46"``. They make
the examples run without the benchmark archives, which the repository never copies.
After a generator changes, ``write_maps()`` writes them again.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layout_text import MAX_SIDE, check_size
from warehouse_phys.world.movingai import write_movingai

#: The folder of the shipped maps, beside this module (package data).
MAP_FOLDER = Path(__file__).resolve().parent / "map_files"


def warehouse(
    shelf_rows: int = 8,
    blocks_per_row: int = 3,
    block_length: int = 10,
    aisle_width: int = 3,
    gap_width: int = 1,
    margin_rows: int = 2,
    margin_cols: int = 7,
) -> tuple[str, ...]:
    """A Kiva-style warehouse floor, as layout rows: ``shelf_rows`` rows of shelves, each
    ``blocks_per_row`` blocks of ``block_length`` shelf cells with ``gap_width`` free
    columns between blocks, ``aisle_width`` free rows between shelf rows, and free
    margins of ``margin_rows`` rows above and below and ``margin_cols`` columns left and
    right. No start is marked (a fleet draws its starts) and every free cell may hold a
    package; the free cells are always connected. The defaults give the classic 33 x 46
    floor of ``kiva-33-46.map``.

    Raises:
        TypeError: naming the argument, if one is not an integer.
        ValueError: naming the argument, if one is out of range, the floor would exceed
            the largest floor, or the margins would leave shelves walling off the floor.
    """
    sizes = {"shelf_rows": shelf_rows, "blocks_per_row": blocks_per_row,
             "block_length": block_length, "aisle_width": aisle_width, "gap_width": gap_width,
             "margin_rows": margin_rows, "margin_cols": margin_cols}  # fmt: skip
    for name, value in sizes.items():
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{name} must be an integer, got {value!r}")
        least = 1 if name in ("shelf_rows", "blocks_per_row", "block_length", "aisle_width",
                              "gap_width") else 0  # fmt: skip
        if value < least:
            raise ValueError(f"{name} must be at least {least}, got {value}")
    height = 2 * margin_rows + shelf_rows + (shelf_rows - 1) * aisle_width
    width = 2 * margin_cols + blocks_per_row * block_length + (blocks_per_row - 1) * gap_width
    if height > MAX_SIDE or width > MAX_SIDE:
        raise ValueError(
            f"the warehouse would be {height} x {width} cells; the largest floor is "
            f"{MAX_SIDE} x {MAX_SIDE}"
        )
    if height < 2:  # one row of shelves: the gaps between blocks are cut off
        raise ValueError(
            "margin_rows must be at least 1 when shelf_rows is 1: the warehouse would be a "
            "single row of shelves"
        )
    if blocks_per_row == 1 and margin_cols == 0:  # each row of shelves a wall
        raise ValueError(
            "margin_cols must be at least 1 when blocks_per_row is 1: each row of shelves "
            "would wall off the aisles from one another"
        )
    free = "." * width
    blocks = ("." * gap_width).join(["#" * block_length] * blocks_per_row)
    shelves = "." * margin_cols + blocks + "." * margin_cols
    rows = [free] * margin_rows
    for i in range(shelf_rows):
        rows += [free] * (aisle_width if i else 0) + [shelves]
    rows += [free] * margin_rows
    return tuple(rows)


def random_floor(rows: int, cols: int, density: float = 0.1, seed: int = 0) -> tuple[str, ...]:
    """A ``rows`` x ``cols`` floor, as layout rows, on which each cell is a shelf with
    chance ``density``, drawn from a numpy ``Generator`` seeded with ``seed`` (one uniform
    draw a cell, in reading order); the top-left cell is always floor. Nothing keeps the
    floor connected: a fleet uses its largest region, as on MovingAI's random maps.

    Raises:
        TypeError: naming the argument, if a size or the seed is not an integer or the
            density not a number.
        ValueError: naming the argument, for a size outside 2 to the largest floor, a
            density outside [0, 1) or a negative seed.
    """
    rows, cols = check_size("rows", rows), check_size("cols", cols)
    if isinstance(density, bool) or not isinstance(density, (int, float)):
        raise TypeError(f"density must be a number, got {density!r}")
    if not 0 <= density < 1:  # NaN fails too
        raise ValueError(f"density must be in [0, 1), got {density}")
    shelves = np.random.default_rng(_seed(seed)).random((rows, cols)) < density
    shelves[0, 0] = False
    return _layout_rows(shelves)


def maze(rows: int, cols: int, corridor: int = 2, seed: int = 0) -> tuple[str, ...]:
    """A maze, as layout rows: corridors ``corridor`` cells wide between walls one cell
    thick, around a frame of wall. Its rooms (``corridor`` x ``corridor`` squares on a
    lattice of pitch ``corridor + 1``) are joined by a randomised depth-first search drawn
    from ``seed``: one way, and one only, from any room to any other. Rows and columns the
    lattice leaves over at the bottom and the right are wall.

    Raises:
        TypeError: naming the argument, if one is not an integer.
        ValueError: naming the argument, for a size outside 2 to the largest floor, a
            corridor narrower than 1, a floor too small for two rooms, or a negative seed.
    """
    rows, cols = check_size("rows", rows), check_size("cols", cols)
    if isinstance(corridor, bool) or not isinstance(corridor, int):
        raise TypeError(f"corridor must be an integer, got {corridor!r}")
    if corridor < 1:
        raise ValueError(f"corridor must be at least 1, got {corridor}")
    pitch = corridor + 1
    rooms = ((rows - 1) // pitch, (cols - 1) // pitch)
    if min(rooms) < 1 or rooms[0] * rooms[1] < 2:
        raise ValueError(
            f"a maze of corridors {corridor} wide needs two rooms and their walls, "
            f"{pitch + 1} x {2 * pitch + 1} cells or {2 * pitch + 1} x {pitch + 1}, "
            f"got {rows} x {cols}"
        )
    rng = np.random.default_rng(_seed(seed))
    shelves = np.ones((rows, cols), dtype=bool)
    visited = np.zeros(rooms, dtype=bool)
    stack = [(0, 0)]
    visited[0, 0] = True
    shelves[1:pitch, 1:pitch] = False
    while stack:
        r, c = stack[-1]
        ways = [(r + dr, c + dc) for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1))
                if 0 <= r + dr < rooms[0] and 0 <= c + dc < rooms[1]
                and not visited[r + dr, c + dc]]  # fmt: skip
        if not ways:
            stack.pop()
            continue
        nr, nc = ways[int(rng.integers(len(ways)))]
        visited[nr, nc] = True
        stack.append((nr, nc))
        # The room and the wall between: the box spanning both rooms' cells.
        top, left = 1 + min(r, nr) * pitch, 1 + min(c, nc) * pitch
        bottom, right = 1 + max(r, nr) * pitch + corridor, 1 + max(c, nc) * pitch + corridor
        shelves[top:bottom, left:right] = False
    return _layout_rows(shelves)


@dataclass(frozen=True)
class BenchmarkMap:
    """A map the package ships: its name, the generator and arguments that make it."""

    name: str
    generator: Callable[..., tuple[str, ...]]
    arguments: dict[str, Any] = field(default_factory=dict)
    description: str = ""

    def rows(self) -> tuple[str, ...]:
        """The map's floor as layout rows, made now."""
        return self.generator(**self.arguments)


#: The shipped maps by name (their files: :func:`map_path`).
MAPS: dict[str, BenchmarkMap] = {
    entry.name: entry
    for entry in (
        BenchmarkMap(
            "kiva-33-46", warehouse, {},
            "the classic Kiva warehouse of the planning benchmarks, cell for cell: 8 rows of "
            "3 shelf blocks of 10, aisles 3 wide; the floor of published fleet results (192 "
            "robots, 256 steps, lifelong)",
        ),
        BenchmarkMap(
            "kiva-140-500", warehouse,
            {"shelf_rows": 46, "blocks_per_row": 45, "aisle_width": 2, "margin_cols": 3},
            "a Kiva-style floor the size of the League of Robot Runners' warehouse_large "
            "(140 x 500, not its layout): 46 rows of 45 shelf blocks of 10, aisles 2 wide, "
            "49,300 free cells: 10,000 robots, lifelong",
        ),
        BenchmarkMap(
            "random-64-64-10-seed0", random_floor,
            {"rows": 64, "cols": 64, "density": 0.1, "seed": 0},
            "64 x 64, 10 % of the cells shelves at random, seed 0 (the MovingAI benchmark "
            "random-64-64-10 is another draw of the same kind)",
        ),
        BenchmarkMap(
            "maze-32-32-2-seed0", maze, {"rows": 32, "cols": 32, "corridor": 2, "seed": 0},
            "32 x 32, a maze of corridors 2 wide, seed 0 (the MovingAI benchmark "
            "maze-32-32-2 is another maze of the same kind)",
        ),
    )
}  # fmt: skip


def map_path(name: str) -> Path:
    """The shipped ``.map`` file of the map ``name`` (one of :data:`MAPS`).

    Raises:
        ValueError: for an unknown name, listing the known ones.
    """
    if name not in MAPS:
        raise ValueError(f"unknown benchmark map {name!r}; the package ships {', '.join(MAPS)}")
    return MAP_FOLDER / f"{name}.map"


def write_map(name: str, path: str | os.PathLike[str]) -> Path:
    """Write the map ``name`` (one of :data:`MAPS`) as its generator makes it today, as a
    MovingAI file at ``path`` (atomically); returns the path. The shipped file is this.

    Raises:
        ValueError: for an unknown name.
    """
    map_path(name)  # refuses an unknown name
    return write_movingai(WarehouseGrid.from_layout(MAPS[name].rows()), path)


def write_maps(folder: str | os.PathLike[str] = MAP_FOLDER) -> list[Path]:
    """Write every map of :data:`MAPS` into ``folder`` (by default the package's own, after
    a generator changed), as ``<name>.map``; returns the paths."""
    return [write_map(name, Path(folder) / f"{name}.map") for name in MAPS]


def _seed(seed: object) -> int:
    """``seed`` as a generator's seed, or a ``TypeError``/``ValueError`` naming it."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be an integer, got {seed!r}")
    if seed < 0:
        raise ValueError(f"seed must be 0 or more, got {seed}")
    return int(seed)


def _layout_rows(shelves: np.ndarray) -> tuple[str, ...]:
    """A boolean shelf mask as layout rows, a row at a time (no loop over cells)."""
    symbols = np.where(shelves, ord("#"), ord(".")).astype(np.uint8)
    return tuple(row.tobytes().decode("ascii") for row in symbols)
