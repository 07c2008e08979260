"""A fleet's setup: its start cells, and every argument that cannot make a fleet refused
by name (the floor, the counts, the modes, an instance beside floor arguments)."""

import numpy as np
import pytest

from tests.envs.test_fleet_instances import small_instance
from warehouse_phys.envs import fleet


def test_a_fleet_layout_puts_its_robots_on_its_start_cells():
    layout = ["S...S", ".#.#.", "..S..", "PP.PP"]
    env = fleet.parallel_env(num_robots=3, layout=layout)
    env.reset(seed=0)
    assert env.state().reshape(3, 4)[:, :2].tolist() == [[0, 0], [0, 4], [2, 2]]
    assert env.starts == [(0, 0), (0, 4), (2, 2)]
    with pytest.raises(ValueError, match=r"4 robots need 4 start cells; the layout marks 3"):
        fleet.parallel_env(num_robots=4, layout=layout)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"num_robots": 0}, ValueError, "num_robots must be at least 1"),
        ({"num_robots": 2.0}, TypeError, "num_robots must be an integer"),
        ({"num_robots": 5, "grid_rows": 2, "grid_cols": 2}, ValueError, "need 5 start cells"),
        ({"num_robots": 7, "layout": "depot"}, ValueError, "7 robots need 7 package cells away"),
        ({"num_robots": 4, "layout": "depot", "lifelong": True}, ValueError, "need 8 package"),
        ({"physics": "yes"}, TypeError, "physics must be a bool"),
        ({"observation": "pixels"}, ValueError, "observation must be one of"),
        ({"max_cycles": 0}, ValueError, "max_cycles must be 1 to 1,000,000,000, got 0"),
        ({"max_cycles": 2**63}, ValueError, "max_cycles must be 1 to 1,000,000,000, got 9223"),
        ({"robot_radius": 0.7}, ValueError, "robot_radius 0.7 m must be less than half"),
        ({"render_mode": "human"}, ValueError, "render_mode must be None or one of"),
        ({"mass": 3.0}, TypeError, r"unknown argument\(s\) 'mass'; the physical parameters"),
        ({"num_robots": np.timedelta64(3)}, TypeError, "num_robots must be an integer"),
        ({"max_cycles": np.timedelta64(4)}, TypeError, "max_cycles must be an integer"),
        ({"max_cycles": np.timedelta64(7, "s")}, TypeError, "max_cycles must be an integer"),
        ({"num_robots": np.int64(2**40), "observation": "global"}, ValueError,
         "1,099,511,627,776 robots would need 36,893,488,147,419,103,232 MiB a step"),
    ],
)  # fmt: skip
def test_bad_arguments_are_refused_by_name(kwargs, error, message):
    with pytest.raises(error, match=message):
        fleet.parallel_env(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"on_delivery": "vanish"}, "on_delivery must be one of"),
        ({"starts": "anywhere"}, "starts must be one of"),
        ({"lifelong": True, "on_delivery": "park"}, "lifelong=True means"),
        ({"num_robots": 300, "observation": "global", "grid_rows": 40}, "at most 256 robots"),
        ({"num_robots": 10**9, "physics": True}, "1,000,000,000 robots' bodies need about 15,258"),
        ({"physics": True, "on_delivery": "leave"}, "'leave' is for the grid twin"),
    ],
)
def test_bad_modes_are_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        fleet.parallel_env(**kwargs)


@pytest.mark.parametrize("keyword", ["num_robots", "max_cycles"])
def test_counts_with_thousands_of_digits_are_refused_by_name(keyword):
    with pytest.raises(ValueError, match=f"^{keyword} must be (at least 1|1 to 1,000,000,000), "
                       "got a negative integer"):  # fmt: skip
        fleet.parallel_env(**{keyword: -(10**5000)})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"layout": "aisles"}, "an instance gives the floor and the starts; do not give layout"),
        ({"grid_rows": 4, "starts": "random"}, "do not give grid_rows, starts"),
        ({"num_robots": 3}, "num_robots=3 but the instance small-roundrobin has teamSize 5"),
        ({"on_delivery": "park"}, "an instance fleet is lifelong"),
        ({"instance": 7}, "instance must be a LorrInstance or the path of its JSON file"),
        ({"instance": "nowhere.json"}, "nowhere.json: no such instance file"),
        ({"scheduler": lambda r, t, c: r}, "roundrobin.*pass scheduler=None"),
    ],
)
def test_bad_instance_arguments_are_refused_by_name(kwargs, message):
    kwargs = {"instance": small_instance(), **kwargs}
    with pytest.raises((ValueError, TypeError), match=message):
        fleet.parallel_env(**kwargs)
    with pytest.raises(ValueError, match="scheduler is for a fleet of an instance"):
        fleet.parallel_env(scheduler=lambda r, t, c: r)
