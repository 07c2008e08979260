"""The plan checks: fleets, plans and delays the executor cannot run are refused in one
line, naming the argument."""

import numpy as np
import pytest

from tests.execution.test_executor import corridor
from warehouse_phys.execution.executor import Executor
from warehouse_phys.world.grid import WarehouseGrid


def test_plans_that_cannot_be_executed_are_refused_in_one_line():
    grid = WarehouseGrid.from_layout(["S.", ".."])
    cells = np.array([(0, 0), (0, 1), (1, 1), (1, 0)])
    executor = Executor(grid, cells, [1, 2, 1, 1])
    turned = cells[[1, 2, 3, 0]]
    cases = {
        r"rotates robot 0 .ticks_needed 1": np.stack([cells, turned], axis=1),
        "swaps robots": np.stack([cells, cells[[1, 0, 2, 3]]], axis=1),
        "puts robots": np.stack([cells, cells[[1, 1, 2, 3]]], axis=1),
        "not a move": np.stack([cells, cells[[2, 1, 0, 3]]], axis=1),
        "must start from plan_cells": np.stack([turned, turned], axis=1),
        "shape": cells,
    }
    for message, path in cases.items():
        with pytest.raises(ValueError, match=message) as error:
            executor.add_plan(path)
        assert "\n" not in str(error.value)
    assert executor.window_done()  # nothing half-added
    wide = Executor(grid, cells, 1, min_gap=0.8)  # a rotation passes corners sqrt(1/2) apart
    with pytest.raises(ValueError, match=r"rotates robot 0 .*min_gap 0.8"):
        wide.add_plan(np.stack([cells, turned], axis=1))


@pytest.mark.parametrize(
    ("cells", "ticks", "message"),
    [([(0, 0), (0, 0)], 1, "share a cell"), ([(0, 9)], 1, "off the floor"),
     ([(0, 0)], 0, "at least 1"), ([(0, 0)], [1, 2], "one per robot")],
)  # fmt: skip
def test_fleets_that_cannot_be_executed_are_refused(cells, ticks, message):
    grid = WarehouseGrid.from_layout(["S.", ".."])
    with pytest.raises(ValueError, match=message):
        Executor(grid, np.array(cells), ticks)
    with pytest.raises(TypeError, match="ticks_needed"):
        Executor(grid, np.array([(0, 0)]), 1.5)
    for gap in (0, -0.5, 1.5, float("nan")):
        with pytest.raises(ValueError, match="min_gap must be in"):
            Executor(grid, np.array([(0, 0)]), 1, gap)
    with pytest.raises(TypeError, match="min_gap"):
        Executor(grid, np.array([(0, 0)]), 1, "0.8")


def test_delays_must_be_one_flag_a_robot():
    executor = corridor(2, 1)
    with pytest.raises(ValueError, match="delayed"):
        executor.step(np.array([1, 0]))
