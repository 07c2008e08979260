"""One-way lanes: every one-cell-wide corridor gets a way, neighbouring corridors the
opposite ways, and nothing else gets one."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.planners.lanes import NO_LANE, floor_lanes, one_way_lanes
from warehouse_phys.world.grid import ACTION_DELTAS, Action, WarehouseGrid

#: A grid of aisles one cell wide round six blocks of shelves (rows 2 and 4), walled.
AISLES = [
    "#########",
    "#.......#",
    "#.##.##.#",
    "#.......#",
    "#.##.##.#",
    "#.......#",
    "#########",
]


def lane_map(layout):
    """The lanes of ``layout`` as a ``(rows, cols)`` array (``NO_LANE`` on shelves too)."""
    free = np.asarray(WarehouseGrid.from_layout(layout).free_mask)
    lanes = np.full(free.shape, NO_LANE, dtype=np.int8)
    lanes[free] = one_way_lanes(free)
    return lanes


def test_aisles_alternate_and_loop_round_every_other_block():
    """Corridor rows alternate west, east, west; corridor columns south, north, south: the
    lanes round the first block of shelves run west along its top, south down its left
    side, east along its bottom and north up its right side; crossings have no lane."""
    lanes = lane_map(AISLES)
    left, down, right, up = Action.LEFT, Action.DOWN, Action.RIGHT, Action.UP
    for row, way in ((1, left), (3, right), (5, left)):
        assert lanes[row, [2, 3, 5, 6]].tolist() == [way] * 4
    for col, way in ((1, down), (4, up), (7, down)):
        assert lanes[[2, 4], col].tolist() == [way] * 2
    assert (lanes[np.ix_([1, 3, 5], [1, 4, 7])] == NO_LANE).all()  # the crossings
    assert (lanes != NO_LANE).sum() == 3 * 4 + 3 * 2
    transposed = lane_map(["".join(column) for column in zip(*AISLES, strict=True)])
    assert transposed[1, 2] == left  # the first corridor column, now a row, runs west
    assert transposed[2, 1] == down  # the first corridor row, now a column, runs south


def test_open_floor_has_no_lane_and_a_single_row_is_one_corridor():
    assert (lane_map(["....."] * 5) == NO_LANE).all()
    assert lane_map(["....."]).tolist() == [[NO_LANE, Action.LEFT, Action.LEFT, Action.LEFT,
                                              NO_LANE]]  # fmt: skip


@settings(max_examples=80, deadline=None)
@given(
    rows=st.integers(1, 12),
    cols=st.integers(1, 12),
    density=st.floats(0.0, 0.7),
    seed=st.integers(0, 2**32 - 1),
)
def test_a_lane_runs_along_a_corridor_one_cell_wide(rows, cols, density, seed):
    """On any floor: a cell has a lane exactly when it is free, both its neighbours one way
    are free and both the other way are not; the lane runs that way; and neighbouring
    corridor rows (or columns) run opposite ways."""
    free = np.random.default_rng(seed).random((rows, cols)) >= density
    lanes = np.full(free.shape, NO_LANE, dtype=np.int8)
    lanes[free] = one_way_lanes(free)

    def open_(r, c):
        return 0 <= r < rows and 0 <= c < cols and bool(free[r, c])

    for r in range(rows):
        for c in range(cols):
            side = {a: open_(r + dr, c + dc) for a, (dr, dc) in enumerate(ACTION_DELTAS)}
            along_row = side[Action.LEFT] and side[Action.RIGHT]
            across_row = side[Action.UP] or side[Action.DOWN]
            along_col = side[Action.UP] and side[Action.DOWN]
            across_col = side[Action.LEFT] or side[Action.RIGHT]
            if free[r, c] and along_row and not across_row:
                assert lanes[r, c] in (Action.LEFT, Action.RIGHT)
            elif free[r, c] and along_col and not across_col:
                assert lanes[r, c] in (Action.UP, Action.DOWN)
            else:
                assert lanes[r, c] == NO_LANE
    for ways, axis in (((Action.LEFT, Action.RIGHT), 1), ((Action.DOWN, Action.UP), 0)):
        corridor = np.isin(lanes, ways).any(axis=axis)
        for rank, line in enumerate(np.flatnonzero(corridor)):
            cells = lanes[line] if axis == 1 else lanes[:, line]
            assert set(cells[np.isin(cells, ways)].tolist()) == {ways[rank % 2]}


@pytest.mark.parametrize(
    "free", [np.ones(5, dtype=bool), np.ones((3, 3), dtype=np.int64), np.ones((2, 2, 2), bool)]
)
def test_a_floor_that_is_not_a_boolean_mask_is_refused(free):
    with pytest.raises(ValueError, match="free must be a"):
        one_way_lanes(free)
    with pytest.raises(ValueError, match="free must be a"):
        floor_lanes(free)


@settings(max_examples=80, deadline=None)
@given(
    rows=st.integers(1, 12),
    cols=st.integers(1, 12),
    density=st.floats(0.0, 0.7),
    seed=st.integers(0, 2**32 - 1),
)
def test_floor_lanes_run_one_way_along_every_row_and_column(rows, cols, density, seed):
    """On any floor: every cell with a free neighbour left or right has an east-west lane,
    every one with a free neighbour above or below a north-south lane, and no other; all
    the lanes of a row run one way, and so do a column's; a corridor cell's lane is its
    :func:`one_way_lanes` lane; rows without corridors run by their parity, as columns."""
    free = np.random.default_rng(seed).random((rows, cols)) >= density
    ways = np.full((rows, cols, 2), NO_LANE, dtype=np.int8)
    ways[free] = floor_lanes(free)
    corridor = np.full(free.shape, NO_LANE, dtype=np.int8)
    corridor[free] = one_way_lanes(free)
    walled = np.pad(free, 1)
    sideways = walled[1:-1, :-2] | walled[1:-1, 2:]
    upright = walled[:-2, 1:-1] | walled[2:, 1:-1]
    assert ((ways[..., 0] != NO_LANE) == (free & sideways)).all()
    assert ((ways[..., 1] != NO_LANE) == (free & upright)).all()
    for axis, line_of in ((0, lambda r: ways[r, :, 0]), (1, lambda c: ways[:, c, 1])):
        for line in range(free.shape[axis]):
            cells = line_of(line)
            assert len(set(cells[cells != NO_LANE].tolist())) <= 1
    in_row = np.isin(corridor, (Action.LEFT, Action.RIGHT))
    in_col = np.isin(corridor, (Action.DOWN, Action.UP))
    assert (ways[..., 0][in_row] == corridor[in_row]).all()
    assert (ways[..., 1][in_col] == corridor[in_col]).all()
    for r in np.flatnonzero(~in_row.any(axis=1)):
        assert set(ways[r, :, 0].tolist()) <= {NO_LANE, (Action.LEFT, Action.RIGHT)[r % 2]}
    for c in np.flatnonzero(~in_col.any(axis=0)):
        assert set(ways[:, c, 1].tolist()) <= {NO_LANE, (Action.DOWN, Action.UP)[c % 2]}


def test_open_floor_lanes_alternate_row_by_row_and_column_by_column():
    ways = np.full((4, 4, 2), NO_LANE, dtype=np.int8)
    ways[np.ones((4, 4), dtype=bool)] = floor_lanes(np.ones((4, 4), dtype=bool))
    assert ways[:, 0, 0].tolist() == [Action.LEFT, Action.RIGHT] * 2
    assert ways[0, :, 1].tolist() == [Action.DOWN, Action.UP] * 2
