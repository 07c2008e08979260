"""The turning robot's rules: headings, turns, the state table and its traffic rule."""

import itertools

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.world.test_traffic import greatest_consistent_movers
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import (
    HEADING_MOVES,
    MOVE_HEADINGS,
    Heading,
    TurnAction,
    quarter_turns,
    resolve_turning_moves,
    state_table,
    turn_towards,
    turned,
    turning_moves,
)
from warehouse_phys.world.traffic import WAIT

FLOOR = WarehouseGrid.from_layout(["...", ".#.", "..."])


def test_turns_go_clockwise_from_east_and_a_forward_move_follows_the_heading():
    headings = np.arange(4)
    assert turned(headings, np.full(4, TurnAction.CLOCKWISE)).tolist() == [1, 2, 3, 0]
    assert turned(headings, np.full(4, TurnAction.COUNTERCLOCKWISE)).tolist() == [3, 0, 1, 2]
    assert turned(headings, np.full(4, TurnAction.FORWARD)).tolist() == [0, 1, 2, 3]
    assert [Heading(h).name for h in headings] == ["EAST", "SOUTH", "WEST", "NORTH"]
    # East is along a row (column + 1), south down the rows: the competition's orientations.
    grid = WarehouseGrid(3, 3)
    moves = [tuple(grid.move((1, 1), int(HEADING_MOVES[h]))) for h in headings]
    assert moves == [(1, 2), (2, 1), (1, 0), (0, 1)]
    assert MOVE_HEADINGS[HEADING_MOVES].tolist() == [0, 1, 2, 3]


@pytest.mark.parametrize(("heading", "wanted", "turns", "action"), [
    (0, 0, 0, TurnAction.WAIT), (0, 1, 1, TurnAction.CLOCKWISE), (0, 2, 2, TurnAction.CLOCKWISE),
    (0, 3, 1, TurnAction.COUNTERCLOCKWISE), (3, 0, 1, TurnAction.CLOCKWISE),
    (2, 1, 1, TurnAction.COUNTERCLOCKWISE),
])  # fmt: skip
def test_the_shorter_turn_towards_a_heading(heading, wanted, turns, action):
    assert quarter_turns(np.array([heading]), np.array([wanted]))[0] == turns
    assert turn_towards(np.array([heading]), np.array([wanted]))[0] == action
    after = turned(np.array([heading]), np.array([action]))[0]
    assert quarter_turns(np.array([after]), np.array([wanted]))[0] == max(turns - 1, 0)


def test_the_state_table_follows_the_grids_moves_and_the_turns():
    table = state_table(FLOOR)
    cols = FLOOR.cols
    for state in range(FLOOR.rows * cols * 4):
        cell, heading = divmod(state, 4)
        row, col = divmod(cell, cols)
        ahead = FLOOR.move((row, col), int(HEADING_MOVES[heading]))
        assert table[state, TurnAction.FORWARD] == (ahead[0] * cols + ahead[1]) * 4 + heading
        assert table[state, TurnAction.CLOCKWISE] == cell * 4 + (heading + 1) % 4
        assert table[state, TurnAction.COUNTERCLOCKWISE] == cell * 4 + (heading - 1) % 4
        assert table[state, TurnAction.WAIT] == state


def as_grid_actions(headings, actions):
    """A turning robot's forward move is a grid move along its heading; a turn or a wait
    keeps its cell, as a grid WAIT does."""
    return [int(HEADING_MOVES[h]) if a == TurnAction.FORWARD else WAIT
            for h, a in zip(headings, actions, strict=True)]  # fmt: skip


@pytest.mark.parametrize("corner_follows", [True, False])
def test_the_rule_on_every_placement_heading_and_action_of_two_robots(corner_follows):
    free = sorted(FLOOR.reachable)
    checked = 0
    for cells in itertools.permutations(free, 2):
        cells = [tuple(c) for c in cells]
        for headings in itertools.product(range(4), repeat=2):
            for actions in itertools.product(range(4), repeat=2):
                ends, after, refused = resolve_turning_moves(
                    FLOOR, cells, list(headings), list(actions), corner_follows=corner_follows
                )
                expected, wanted = greatest_consistent_movers(
                    FLOOR, cells, as_grid_actions(headings, actions), corner_follows
                )
                assert [tuple(e) for e in ends] == expected
                assert after.tolist() == turned(np.array(headings), np.array(actions)).tolist()
                for i in range(2):
                    assert refused[i] == (wanted[i] != cells[i] and tuple(ends[i]) == cells[i])
                checked += 1
    assert checked == len(free) * (len(free) - 1) * 16 * 16


@given(
    rows=st.integers(2, 8),
    cols=st.integers(2, 8),
    seed=st.integers(0, 2**32 - 1),
    density=st.floats(0.05, 0.9),
    corner_follows=st.booleans(),
)
def test_no_two_robots_ever_share_a_cell_or_swap(rows, cols, seed, density, corner_follows):
    rng = np.random.default_rng(seed)
    grid = WarehouseGrid(rows, cols)
    n = max(1, int(density * rows * cols))
    here = rng.choice(rows * cols, n, replace=False)
    headings = rng.integers(4, size=n)
    actions = rng.integers(4, size=n)
    grants = turning_moves(grid, here, headings, actions, None, corner_follows=corner_follows)
    assert len(np.unique(grants.ends)) == n
    moved = grants.ends != here
    occupant = {cell: robot for robot, cell in enumerate(here.tolist())}
    for robot in np.flatnonzero(moved).tolist():
        other = occupant.get(int(grants.ends[robot]))
        assert other is None or grants.ends[other] != here[robot]  # no swap
        assert actions[robot] == TurnAction.FORWARD
    turning = (actions == TurnAction.CLOCKWISE) | (actions == TurnAction.COUNTERCLOCKWISE)
    assert (grants.headings != headings).tolist() == turning.tolist()


def test_parked_robots_neither_move_nor_turn_and_bad_arguments_are_refused():
    ends, after, refused = resolve_turning_moves(
        FLOOR, [(0, 0), (0, 1)], [0, 0], [0, 1], parked=[False, True]
    )
    assert [tuple(e) for e in ends] == [(0, 0), (0, 1)]
    assert after.tolist() == [0, 0]
    assert refused.tolist() == [True, False]  # the robot ahead stays: traffic refuses
    with pytest.raises(ValueError, match=r"robot 1's heading must be 0\.\.3, got 4"):
        resolve_turning_moves(FLOOR, [(0, 0), (0, 1)], [0, 4], [0, 0])
    with pytest.raises(ValueError, match="one integer action per robot"):
        resolve_turning_moves(FLOOR, [(0, 0)], [0], [0.5])
    with pytest.raises(ValueError, match="share a cell"):
        resolve_turning_moves(FLOOR, [(0, 0), (0, 0)], [0, 0], [0, 0])
    ends, after, _ = resolve_turning_moves(FLOOR, [(0, 2)], [0], [0])
    assert tuple(ends[0]) == (0, 2)  # a forward move into the wall: the floor refuses it
