"""2026 instances made from a floor: deterministic, robots on distinct reachable cells, tasks
of reachable errands, written and read back as the competition's files."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.lorr.tiny_kit_instance import LAYOUT
from warehouse_phys.lorr.generator import EXAMPLE_DELAYS, make_instance
from warehouse_phys.lorr.instances import read_instance, write_instance
from warehouse_phys.world.grid import WarehouseGrid

FLOOR = WarehouseGrid.from_layout(LAYOUT)


@given(st.integers(1, 40), st.integers(1, 50), st.integers(1, 4), st.integers(0, 2**40))
def test_an_instance_is_the_same_for_a_seed_and_keeps_to_the_floor(robots, tasks, stops, seed):
    one = make_instance(FLOOR, robots, tasks, stops=stops, seed=seed)
    two = make_instance(FLOOR, robots, tasks, stops=stops, seed=seed)
    assert (one.starts == two.starts).all()
    assert (one.task_stops == two.task_stops).all()
    reachable = FLOOR.reachable_mask.reshape(-1)
    assert np.unique(one.starts).size == robots
    assert reachable[one.starts].all()
    assert reachable[one.task_stops].all()
    assert one.num_tasks == tasks
    errands = one.task_stops.reshape(tasks, stops)
    assert (errands[:, 1:] != errands[:, :-1]).all()
    assert (one.version, one.agent_counter, one.agent_size, one.delay) == (
        "2026 LoRR",
        3,
        1.0,
        EXAMPLE_DELAYS,
    )


def test_an_instance_is_written_and_read_back_as_the_kit_reads_it(tmp_path):
    made = make_instance(FLOOR, 8, 30, seed=1, name="made")
    back = read_instance(write_instance(made, tmp_path / "made.json"))
    assert (back.starts == made.starts).all()
    assert (back.task_stops == made.task_stops).all()
    assert (back.agent_counter, back.agent_size, back.delay) == (3, 1.0, EXAMPLE_DELAYS)


def test_more_robots_than_cells_and_bad_settings_are_refused():
    with pytest.raises(ValueError, match="robots"):
        make_instance(FLOOR, 10_000, 5)
    with pytest.raises(ValueError, match="agent_size"):
        make_instance(FLOOR, 2, 5, agent_size=2.0)
    with pytest.raises(ValueError, match="agent_counter"):
        make_instance(FLOOR, 2, 5, agent_counter=0)
    with pytest.raises(TypeError, match="delay"):
        make_instance(FLOOR, 2, 5, delay={"pDelay": 0.1})
