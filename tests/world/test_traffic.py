"""The fleet's traffic rule, checked exhaustively for two and three robots on small floors."""

import itertools
from pathlib import Path

import numpy as np
import pytest

from tests.world.golden_traffic import FLOORS as FLOORS_OF_GOLDEN
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import (
    CORNER_FOLLOW_DISTANCE,
    WAIT,
    check_clearance,
    corner_follows_are_safe,
    granted_moves,
    moves_refused_by_floor,
    neighbour_table,
    resolve_moves,
)

FLOORS = {
    "2x3": WarehouseGrid(2, 3),
    "3x3 with a shelf": WarehouseGrid.from_layout(["...", ".#.", "..."]),
}


def greatest_consistent_movers(grid, cells, actions, corner_follows):
    """The rule by brute force: after the lowest-numbered-goes rule, the largest set of
    movers in which every mover's cell is free, or left by a mover of the set straight
    ahead (or round a corner, if allowed), and no two swap."""
    n = len(cells)
    wanted = [
        cells[i] if a == WAIT else tuple(grid.move(cells[i], a)) for i, a in enumerate(actions)
    ]
    candidates = []
    for i in range(n):
        if wanted[i] != cells[i] and all(wanted[k] != wanted[i] for k in candidates):
            candidates.append(i)

    def consistent(movers):
        for i in movers:
            if wanted[i] in cells:
                j = cells.index(wanted[i])
                if j not in movers or wanted[j] == cells[i]:
                    return False
                d_i = (wanted[i][0] - cells[i][0], wanted[i][1] - cells[i][1])
                d_j = (wanted[j][0] - cells[j][0], wanted[j][1] - cells[j][1])
                if d_i != d_j and not corner_follows:
                    return False
        return True

    best = set()
    for size in range(len(candidates) + 1):
        for movers in itertools.combinations(candidates, size):
            if consistent(set(movers)):
                best |= set(movers)
    assert consistent(best)  # the union of consistent sets is consistent: one answer
    return [wanted[i] if i in best else cells[i] for i in range(n)], wanted


@pytest.mark.parametrize("corner_follows", [True, False])
@pytest.mark.parametrize(("name", "n_robots"), [("2x3", 2), ("3x3 with a shelf", 2),
                                                ("3x3 with a shelf", 3)])  # fmt: skip
def test_the_rule_on_every_placement_and_joint_action(name, n_robots, corner_follows):
    grid = FLOORS[name]
    free = sorted(grid.reachable)
    checked = 0
    # The rule takes arrays, as the fleet passes them (quicker to read than tuples).
    joints = [(a, np.array(a)) for a in itertools.product(range(5), repeat=n_robots)]
    for cells in itertools.permutations(free, n_robots):
        cells = [tuple(c) for c in cells]
        placed = np.array(cells)
        for actions, joint in joints:
            ends, refused = resolve_moves(grid, placed, joint, corner_follows=corner_follows)
            ends, refused = [tuple(e) for e in ends.tolist()], refused.tolist()
            expected, wanted = greatest_consistent_movers(grid, cells, actions, corner_follows)
            assert ends == expected, (cells, actions)
            assert len(set(ends)) == n_robots  # never two robots on a cell
            for i in range(n_robots):
                assert ends[i] in (cells[i], wanted[i])  # a granted move or a wait
                assert refused[i] == (wanted[i] != cells[i] and ends[i] == cells[i])
                for j in range(n_robots):
                    assert not (i != j and ends[i] == cells[j] and ends[j] == cells[i])  # no swap
            checked += 1
    assert checked > 100


def test_chains_and_rotations_move_together_and_corners_need_small_robots():
    grid = WarehouseGrid(3, 4)
    # A straight chain of three following each other to the right.
    ends, refused = resolve_moves(grid, [(0, 0), (0, 1), (0, 2)], [2, 2, 2])
    assert [tuple(e) for e in ends] == [(0, 1), (0, 2), (0, 3)]
    assert refused.tolist() == [False] * 3
    # Blocked at the head: the whole chain waits.
    ends, refused = resolve_moves(grid, [(0, 1), (0, 2), (0, 3)], [2, 2, 2])
    assert [tuple(e) for e in ends] == [(0, 1), (0, 2), (0, 3)]
    assert refused.tolist() == [True, True, False]  # the head bumps the wall: the floor refused it
    # A rotation of four in a 2 x 2 block: every follow is a corner.
    block, turn = [(0, 0), (0, 1), (1, 1), (1, 0)], [2, 1, 0, 3]
    ends, _ = resolve_moves(grid, block, turn, corner_follows=True)
    assert [tuple(e) for e in ends] == [(0, 1), (1, 1), (1, 0), (0, 0)]
    ends, refused = resolve_moves(grid, block, turn, corner_follows=False)
    assert [tuple(e) for e in ends] == block
    assert all(refused)
    # Two robots swapping both wait; a parked robot is an obstacle.
    assert resolve_moves(grid, [(0, 0), (0, 1)], [2, 0])[1].tolist() == [True, True]
    ends, refused = resolve_moves(grid, [(0, 0), (0, 1)], [2, 2], parked=[False, True])
    assert [tuple(e) for e in ends] == [(0, 0), (0, 1)]
    assert refused.tolist() == [True, False]


def test_corner_follows_are_safe_below_the_geometric_threshold():
    assert abs(CORNER_FOLLOW_DISTANCE - 0.70711) < 1e-5
    assert corner_follows_are_safe(0.6)  # the default robot
    assert not corner_follows_are_safe(0.68)
    assert not corner_follows_are_safe(0.71)


@pytest.mark.parametrize(
    ("cells", "actions", "message"),
    [
        ([(0, 0), (0, 0)], [WAIT, WAIT], "two robots share a cell"),
        ([(0, 0), (0, 1)], [5, WAIT], "robot 0's action must be 0..4"),
    ],
)
def test_bad_input_is_refused(cells, actions, message):
    with pytest.raises(ValueError, match=message):
        resolve_moves(WarehouseGrid(2, 3), cells, actions)


def test_the_rule_grants_what_its_first_version_granted():
    """Golden outcomes recorded from the loop-until-stable version of the rule
    (``tests/world/golden_traffic.py``), over four floors, sparse to full fleets, parked
    robots and both corner settings."""
    with np.load(Path(__file__).with_name("traffic_golden.npz")) as stored:
        golden = dict(stored)
    grids = [make() for make in FLOORS_OF_GOLDEN.values()]
    for case in range(len(golden["n"])):
        n = golden["n"][case]
        ends, refused = resolve_moves(
            grids[golden["floor"][case]],
            golden["cells"][case, :n],
            golden["actions"][case, :n],
            golden["parked"][case, :n],
            corner_follows=bool(golden["corner"][case]),
        )
        np.testing.assert_array_equal(np.asarray(ends), golden["ends"][case, :n])
        np.testing.assert_array_equal(np.asarray(refused), golden["refused"][case, :n])


def test_the_clearance_check_names_the_tight_situation_and_the_bound():
    check_clearance(0.6, 0.0, 0.0, 0.0)  # the default robot and controller
    check_clearance(0.96, 0.0, 0.0, 0.0)  # discs nearly a cell wide, no overshoot
    message = (r"head-on come within 1 - 2 x 0\.2 = 0\.6 cells, less than the diameter plus "
               r"a margin of 0\.02 \(0\.62\); the diameter may be at most 0\.58 cells")  # fmt: skip
    with pytest.raises(ValueError, match=message):
        check_clearance(0.6, 0.2, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"bumping back to back come within 1 - 2 x 0\.2 "):
        check_clearance(0.6, 0.0, 0.2, 0.0)  # a bump's return counts the same
    check_clearance(0.58, 0.2, 0.0, 0.0)  # the largest diameter allowed
    with pytest.raises(ValueError, match=r"= -0\.2 cells, .*; no robot is small enough for"):
        check_clearance(0.1, 0.6, 0.0, 0.0)  # no diameter would do: none is offered
    # Drifting sideways narrows a corner follow: refused where corner follows are granted.
    corner = (r"round a corner: .* within sqrt\(0\.5\) - 2 x 0\.05 = 0\.607 cells, less than "
              r"0\.62; the diameter may be at most 0\.587 cells, or at least 0\.657")  # fmt: skip
    with pytest.raises(ValueError, match=corner):
        check_clearance(0.6, 0.0, 0.0, 0.05)
    check_clearance(0.7, 0.0, 0.0, 0.05)  # too large for corner follows: none are granted


def test_the_rule_names_the_bumps_the_floor_refuses():
    grid = WarehouseGrid.from_layout(["S.#..", ".....", "..#.."])
    rng = np.random.default_rng(2)
    cells = np.array([(r, c) for r in range(3) for c in range(5) if (r, c) not in grid.shelves])
    for _ in range(200):
        n = int(rng.integers(1, len(cells)))
        here = cells[rng.choice(len(cells), n, replace=False)]
        actions = rng.integers(5, size=n)
        parked = rng.random(n) < 0.2
        index = here[:, 0] * grid.cols + here[:, 1]
        grants = granted_moves(grid, index, actions, parked)
        moves = zip(here.tolist(), actions.tolist(), parked.tolist(), strict=True)
        expected = [a != WAIT and not p and grid.move(tuple(c), a) == tuple(c) for c, a, p in moves]
        assert grants.bumped.tolist() == expected
        assert moves_refused_by_floor(grid, here, actions, parked).tolist() == expected
        assert not (grants.bumped & grants.refused).any()  # the floor's, not traffic's


@pytest.mark.parametrize(
    "layout",
    [["S.#..", "..#.#", "....#"], ["S.", "#."], ["S##.", "..#.", "#...", "..#."]],
)  # fmt: skip
def test_the_neighbour_table_is_the_grids_move_and_a_wait(layout):
    grid = WarehouseGrid.from_layout(layout)
    table = neighbour_table(grid)
    assert not table.flags.writeable
    for row in range(grid.rows):
        for col in range(grid.cols):
            cell = row * grid.cols + col
            assert table[cell, WAIT] == cell
            if grid.is_free((row, col)):
                for action in range(4):
                    r, c = grid.move((row, col), action)
                    assert table[cell, action] == r * grid.cols + c


def test_the_neighbour_table_of_the_largest_floor_is_built_from_its_mask():
    grid = WarehouseGrid(2048, 2048)
    table = neighbour_table(grid)
    assert table.shape == (2048 * 2048, 5)
    assert table[0].tolist() == [0, 2048, 1, 0, 0]
    last = 2048 * 2048 - 1  # the bottom right corner: left and up only
    assert table[last].tolist() == [last - 1, last, last, last - 2048, last]
