"""The follow rule: a robot follows the one ahead into the cell it leaves keeping their
centres ``min_gap`` apart, and ends its move only as its leader's ends."""

import numpy as np
import pytest

from tests.execution.test_executor import straight_path
from warehouse_phys.execution.executor import Executor
from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.world.grid import WarehouseGrid


@pytest.mark.parametrize(
    ("min_gap", "expected"),
    [  # robot 0 takes 3 ticks a move, robot 1, behind it, 2
        # Both start; robot 1 would come 2/3 of a cell behind, so stops; both end.
        (DEFAULT_MIN_GAP, [([True, True], [1, 1]), ([True, False], [2, 1]),
                           ([True, True], [0, 0])]),
        # A whole cell: robot 1 waits a tick, then goes only as robot 0 goes.
        (1.0, [([True, False], [1, 0]), ([True, True], [2, 1]), ([True, True], [0, 0])]),
    ],
)  # fmt: skip
def test_a_follower_keeps_its_gap_to_the_robot_ahead(min_gap, expected):
    grid = WarehouseGrid.from_layout(["S" + "." * 9, "." * 10])
    executor = Executor(grid, np.array([(0, 1), (0, 0)]), [3, 2], min_gap)
    executor.add_plan(straight_path(executor, 1))
    heads = []
    for _ in range(3):
        report = executor.step()
        heads.append((report.go.tolist(), executor.done.tolist()))
    assert heads == expected
    assert executor.window_done()


def test_round_a_corner_a_follower_keeps_its_gap_and_arrives_only_as_its_leader_leaves():
    """Robot 0 (10 ticks a move) goes down out of (0, 1) as robot 1 (2 ticks) follows in
    from the left: robot 1 starts once the gap allows, then waits in mid-move and ends
    its move on the tick robot 0's ends, not before (one robot leaves a cell at a time)."""
    grid = WarehouseGrid.from_layout(["S..", "..."])
    executor = Executor(grid, np.array([(0, 1), (0, 0)]), [10, 2])
    executor.add_plan(np.array([[(0, 1), (1, 1)], [(0, 0), (0, 1)]]))
    follower = []
    for _ in range(10):
        executor.step()
        follower.append(int(executor.done[1]))
    # sqrt(l**2 + (1 - f)**2) >= sqrt(1/2): half way (f = 1/2) once l >= 1/2.
    assert follower == [0, 0, 0, 0, 1, 1, 1, 1, 1, 0]
    assert executor.held().tolist() == [[4, 4], [1, 1]]
