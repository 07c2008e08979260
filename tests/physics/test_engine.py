"""The floor's static shapes: the shelves as boxes, one a horizontal run of shelf cells,
that cover their cells exactly."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.physics import PhysicsConfig, add_floor, new_space
from warehouse_phys.world.grid import WarehouseGrid


def shelf_boxes(grid: WarehouseGrid, cell: float = 1.0, origin=(0.0, 0.0)):
    """Each shelf box's cells as (top, bottom, left, right) row/column bounds, end excluded
    (the four walls lie outside the floor and are left out)."""
    space = new_space(PhysicsConfig())
    add_floor(space, grid, cell, origin)
    boxes = []
    for shape in space.shapes:
        xs = [(v.x - origin[0]) / cell for v in shape.get_vertices()]
        ys = [(v.y - origin[1]) / cell for v in shape.get_vertices()]
        if min(xs) < 0 or min(ys) < 0 or max(xs) > grid.cols or max(ys) > grid.rows:
            continue  # a wall
        box = (min(ys), max(ys), min(xs), max(xs))
        assert np.allclose(box, np.round(box)), box  # on the cells' edges
        boxes.append(tuple(round(b) for b in box))
    return boxes


@settings(max_examples=150, deadline=None)
@given(
    rows=st.integers(1, 9),
    cols=st.integers(1, 9),
    bits=st.integers(0, 2**100 - 1),
    cell=st.sampled_from([1.0, 0.5, 2.0]),
)
def test_the_shelf_boxes_cover_every_shelf_cell_once_and_nothing_else(rows, cols, bits, cell):
    # Shelves anywhere but the top row and the left column, which stay floor (a floor
    # must have room for a package).
    shelf = [
        [r > 0 and c > 0 and bool(bits >> (r * cols + c) & 1) for c in range(cols + 1)]
        for r in range(rows + 1)
    ]
    grid = WarehouseGrid.from_layout(["".join("#" if s else "." for s in row) for row in shelf])
    cover = np.zeros((rows + 1, cols + 1), dtype=np.int64)
    for top, bottom, left, right in shelf_boxes(grid, cell, (3.0, -1.5)):
        cover[top:bottom, left:right] += 1
    assert (cover == np.array(shelf, dtype=np.int64)).all()


def test_each_horizontal_run_of_shelf_cells_is_one_box():
    # A 2 x 3 block is two boxes, one a row; an L of three cells is two.
    layout = (
        ".......",
        ".###.#.",
        ".###.##",
        ".......",
    )
    boxes = sorted(shelf_boxes(WarehouseGrid.from_layout(layout)))
    assert boxes == [(1, 2, 1, 4), (1, 2, 5, 6), (2, 3, 1, 4), (2, 3, 5, 7)]
