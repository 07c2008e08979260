"""Map frames of a fleet on a large floor, drawn with array operations: no pygame, no
sprites, one pass however many robots (:func:`fleet_map_frame`), and the array stamps
the pygame renderer uses for a fleet on small cells (:func:`stamp_fleet`,
:func:`stamp_headings`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np

from warehouse_phys.drawing.colours import DELIVERED_FRAME, FLEET_COLOURS, HEADING_POINTER

#: Robot colours for map frames: :data:`FLEET_COLOURS` as an array [RGB].
MAP_ROBOT_COLOURS = np.array(FLEET_COLOURS, dtype=np.uint8)
MAP_FLOOR = (245, 245, 240)  # RGB
#: Shelves in a light grey, so that the near-black packages stand out from them even
#: at 1 or 2 pixels a cell; every robot colour stays far from both.
MAP_SHELF = (185, 185, 195)  # RGB
MAP_PACKAGE = (25, 25, 25)  # RGB: a dark dot, left visible in a robot standing on it
MAP_DELIVERED = DELIVERED_FRAME  # RGB: a parked robot that delivered
#: Widest map frame drawn by :func:`fleet_map_frame` when it chooses the cell size [px].
MAP_FRAME_WIDTH_PX = 1000


def _stamp(
    frame: np.ndarray, tops: np.ndarray, lefts: np.ndarray, mask: np.ndarray, colours: Any
) -> None:
    """Paint ``mask`` (a ``(px, px)`` bool array) at each ``(tops[i], lefts[i])`` of
    ``frame`` in ``colours[i]`` (or one colour for all), with array operations."""
    ys, xs = np.nonzero(mask)
    colours = np.asarray(colours, dtype=np.uint8).reshape(-1, 3)
    frame[tops[:, None] + ys, lefts[:, None] + xs] = colours[:, None, :]


def stamp_fleet(
    frame: np.ndarray,
    px: int,
    border: int,
    robots: Sequence[Sequence[float]],
    packages: Sequence[tuple[int, int]],
    delivered: Sequence[bool] | None,
) -> None:
    """A fleet's packages (dark squares framed ``border`` px wide in their robot's colour),
    robots (discs of their colour; a package's frame shows round a robot standing on it)
    and green frames round the delivered robots, painted onto ``frame``."""
    n = len(robots)
    if n == 0:
        return
    colours = MAP_ROBOT_COLOURS[np.arange(n) % len(MAP_ROBOT_COLOURS)]
    centre = (np.arange(px) + 0.5 - px / 2) ** 2
    disc = centre[:, None] + centre[None, :] <= (px * 9 / 20) ** 2
    ring = np.ones((px, px), dtype=bool)
    ring[border:-border, border:-border] = False
    inner = np.zeros((px, px), dtype=bool)
    inner[px // 3 : px - px // 3, px // 3 : px - px // 3] = True
    cells = np.asarray(packages, dtype=np.int64).reshape(-1, 2) * px
    _stamp(frame, cells[:, 0], cells[:, 1], inner, MAP_PACKAGE)
    _stamp(frame, cells[:, 0], cells[:, 1], ring, colours[: len(cells)])
    corners = np.rint(np.asarray(robots, dtype=np.float64).reshape(-1, 2) * px).astype(np.int64)
    _stamp(frame, corners[:, 0], corners[:, 1], disc, colours)
    if delivered is not None:
        done = np.asarray(delivered, dtype=bool)
        _stamp(frame, corners[done, 0], corners[done, 1], ring, DELIVERED_FRAME)


def stamp_headings(
    frame: np.ndarray, px: int, robots: Sequence[Sequence[float]], headings: Sequence[float]
) -> None:
    """Each robot's heading as a dark square between its centre and its rim (cells of
    ``px`` pixels, robots at cell positions), painted with array operations."""
    size = max(1, px // 4)
    angle = np.asarray(headings, dtype=np.float64) * np.pi / 2
    at = np.asarray(robots, dtype=np.float64).reshape(-1, 2) + 0.5
    reach = (px * 9 / 20 - size / 2) / px  # [cells] from the centre
    middle = (at + reach * np.stack([np.sin(angle), np.cos(angle)], axis=1)) * px
    corner = np.rint(middle - size / 2).astype(np.int64)
    limit = np.array(frame.shape[:2]) - size
    corner = np.clip(corner, 0, limit)
    _stamp(frame, corner[:, 0], corner[:, 1], np.ones((size, size), dtype=bool), HEADING_POINTER)


def map_cell_px(rows: int, cols: int, width_px: int = MAP_FRAME_WIDTH_PX) -> int:
    """The cell size [px] that fits the longer side of a ``rows`` x ``cols`` floor in
    ``width_px`` (at least 1, at most 24): 2 px for the 500 x 140 warehouse."""
    return int(np.clip(width_px // max(rows, cols), 1, 24))


@functools.lru_cache(maxsize=4)  # a few floors: a run and its baselines share one
def _floor_image(rows: int, cols: int, px: int, packed_shelves: bytes) -> np.ndarray:
    """The floor and its shelves (``packed_shelves``: the shelf mask through
    ``np.packbits``) at ``px`` pixels a cell, read-only. Cached by content: a large map's
    tens of thousands of shelves are painted once, not on every frame."""
    packed = np.frombuffer(packed_shelves, dtype=np.uint8)
    shelves = np.unpackbits(packed, count=rows * cols).reshape(rows, cols).astype(bool)
    cells = np.empty((rows, cols, 3), dtype=np.uint8)
    cells[:] = MAP_FLOOR
    cells[shelves] = MAP_SHELF
    image = np.repeat(np.repeat(cells, px, axis=0), px, axis=1)
    image.flags.writeable = False
    return image


def _shelf_mask(grid: Any) -> np.ndarray:
    """``grid``'s shelves as a ``(rows, cols)`` boolean array: a
    :class:`~warehouse_phys.world.grid.WarehouseGrid`'s own ``shelf_mask``, else built
    from ``grid.shelves`` (any collection of cells)."""
    mask = getattr(grid, "shelf_mask", None)
    if mask is not None:
        return np.asarray(mask, dtype=bool)
    mask = np.zeros((grid.rows, grid.cols), dtype=bool)
    cells = np.array(list(grid.shelves), dtype=np.int64).reshape(-1, 2)
    mask[cells[:, 0], cells[:, 1]] = True
    return mask


def fleet_map_frame(
    grid: Any,
    robots: np.ndarray,
    packages: np.ndarray,
    *,
    parked: np.ndarray | None = None,
    on_floor: np.ndarray | None = None,
    cell_px: int | None = None,
    headings: np.ndarray | None = None,
) -> np.ndarray:
    """A fleet on a large floor as an ``(H, W, 3)`` uint8 map, drawn with array operations
    (no pygame, no sprites: one pass however many robots): the floor light, shelves light
    grey, packages near-black, robot ``i`` a square in ``MAP_ROBOT_COLOURS[i % 8]``.

    A parked robot (it delivered) is framed in green, as the single robot's delivery is,
    keeping its colour inside, when a cell is 4 px or more; on smaller cells it is a
    green square. Where a robot stands on its or another's package and the cell is 3 px
    or more, the package shows as a dark square in the robot's middle. Robots that left
    the floor are not drawn. ``cell_px`` defaults to :func:`map_cell_px`. With
    ``headings`` (turning robots, 0..3) each robot's cell shows its heading as a dark
    mark on the side it faces, on cells of 3 px or more (a 1- or 2-pixel cell has no
    side to mark).

    The floor and its shelves are drawn once per floor and cell size and copied: a
    frame costs a copy of the picture and work in proportion to the robots, however
    many shelves the floor has.

    Raises:
        ValueError: if ``cell_px`` is below 1.
    """
    rows, cols = grid.rows, grid.cols
    px = map_cell_px(rows, cols) if cell_px is None else int(cell_px)
    if px < 1:
        raise ValueError(f"cell_px must be at least 1, got {cell_px}")
    robots = np.asarray(robots, dtype=np.int64).reshape(-1, 2)
    packages = np.asarray(packages, dtype=np.int64).reshape(-1, 2)
    n = len(robots)
    shown = np.ones(n, dtype=bool) if on_floor is None else np.asarray(on_floor, dtype=bool)
    done = np.zeros(n, dtype=bool) if parked is None else np.asarray(parked, dtype=bool)
    waiting = shown & ~done  # robots whose package is still on the floor
    framed = px >= 4  # a parked robot keeps its colour inside a green frame
    frame = _floor_image(rows, cols, px, np.packbits(_shelf_mask(grid)).tobytes()).copy()
    # Cell (r, c) is blocks[r, :, c, :]: one fancy index paints a whole cell per robot.
    blocks = frame.reshape(rows, px, cols, px, 3)
    blocks[packages[waiting, 0], :, packages[waiting, 1], :] = MAP_PACKAGE
    colours = MAP_ROBOT_COLOURS[np.arange(n) % len(MAP_ROBOT_COLOURS)]
    if not framed:
        colours[done] = MAP_DELIVERED
    at = robots[shown]
    blocks[at[:, 0], :, at[:, 1], :] = colours[shown][:, None, None, :]
    if framed:  # a green frame round each parked robot's cell
        r, c = robots[shown & done].T
        border = max(1, px // 6)
        for side in (slice(0, border), slice(px - border, px)):
            blocks[r, side, c, :] = MAP_DELIVERED
            blocks[r, :, c, side] = MAP_DELIVERED
    if px >= 3:  # packages under robots: a square in the middle of the robot's cell
        occupied = np.zeros((rows, cols), dtype=bool)
        occupied[at[:, 0], at[:, 1]] = True
        under = packages[waiting][occupied[packages[waiting, 0], packages[waiting, 1]]]
        middle = slice(px // 3, px - px // 3)
        blocks[under[:, 0], middle, under[:, 1], middle] = MAP_PACKAGE
    if headings is not None and px >= 3:
        on = at.astype(np.float64)
        stamp_headings(frame, px, on, np.asarray(headings, dtype=np.float64)[shown])
    return frame
