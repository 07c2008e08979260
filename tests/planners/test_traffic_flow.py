"""The guide paths' compiled bookkeeping: a robot rejoining its guide path."""

import numpy as np

from warehouse_phys.planners import graph_search, traffic_flow

#: A corridor of three cells, map columns 0, 1, 2 from west to east.
CORRIDOR = graph_search.move_graph(np.ones((1, 3), dtype=bool))
EAST = 2  # the move graph's order: left, down, right, up


def follow(pool, start, moves, here, rejoin=True):
    """One robot's :func:`~warehouse_phys.planners.traffic_flow.follow_paths`: its path's
    start, moves, cursor and status after, and the flow."""
    flow = np.zeros((3, 4), dtype=np.int32)
    for k in range(moves):
        flow[pool[start + k], EAST] += 1
    path_start, path_moves = np.array([start]), np.array([moves])
    cursor, status = np.zeros(1, dtype=np.int64), np.ones(1, dtype=np.int8)
    traffic_flow.follow_paths(CORRIDOR, flow, pool, path_start, path_moves, cursor,
                              np.array([here]), 3, rejoin, status)  # fmt: skip
    return int(path_start[0]), int(path_moves[0]), int(cursor[0]), int(status[0]), flow


def test_a_robot_pushed_back_takes_the_free_cell_before_its_path():
    # The path 1 -> 2 stored after a free cell: the robot pushed back to cell 0 rejoins.
    pool = np.array([-1, 1, 2, -1], dtype=np.int32)
    start, moves, cursor, status, flow = follow(pool, 1, 1, here=0)
    assert (start, moves, cursor, status) == (0, 2, 0, 0)
    assert pool[:3].tolist() == [0, 1, 2]
    assert flow[:, EAST].tolist() == [1, 1, 0]


def test_a_path_at_the_pools_start_has_no_free_cell_before_it():
    # The same path stored first in the pool: pool[-1] is the pool's last cell, which may
    # hold anything (free-looking here); the robot is off its path, a new search.
    pool = np.array([1, 2, 7, -1], dtype=np.int32)
    start, moves, cursor, status, flow = follow(pool, 0, 1, here=0)
    assert (start, moves, cursor, status) == (0, 1, 0, 1)
    assert pool.tolist() == [1, 2, 7, -1]
    assert flow[:, EAST].tolist() == [0, 1, 0]
