"""The entry's executor as the kit drives it: plans appended, commands before the delays, a
command settled before anything else happens."""

import numpy as np
import pytest

from tests.lorr.tiny_kit_instance import tiny_instance
from warehouse_phys.lorr.startkit.executor import EntryExecutor, plan_steps


def test_the_kits_calls_in_the_kits_order():
    instance = tiny_instance()
    executor = EntryExecutor(instance.grid, instance.starts, 3, horizon=5)
    cells, headings = executor.predicted()
    assert (cells == instance.starts).all()
    assert (headings == 0).all()
    executor.process_new_plan(np.full((8, 2), 3))  # waits only: nothing staged
    go = executor.next_command()
    assert not go.any()
    with pytest.raises(RuntimeError, match="awaits tick_done"):
        executor.process_new_plan(np.zeros((8, 1), dtype=np.int64))
    executor.tick_done(np.zeros(8, dtype=bool))
    with pytest.raises(RuntimeError, match="none is pending"):
        executor.tick_done(np.zeros(8, dtype=bool))
    assert plan_steps(1000, 100, 3) == 4


def test_a_plan_into_a_wall_is_refused_naming_the_robot():
    instance = tiny_instance()
    executor = EntryExecutor(instance.grid, instance.starts, 3, horizon=5)
    cols = instance.grid.cols
    east = cols - 1 - instance.starts % cols  # moves east before the floor ends
    robot = int(np.argmin(east))
    plan = np.full((8, int(east[robot]) + 1), 3)
    plan[robot] = 0  # forward, east, until off the floor
    with pytest.raises(ValueError, match=f"drive robot {robot} into a wall or off the floor"):
        executor.process_new_plan(plan)
