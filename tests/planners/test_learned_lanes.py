"""Lanes learned from traffic: a lane where traffic goes one way, none where it is balanced
or thin, saved and loaded with the floor's digest, and guided plans with them granted by
traffic on any floor."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.planners.test_guidance import play
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import fleet
from warehouse_phys.planners import graph_search
from warehouse_phys.planners.lanes.learned import TrafficLanes, floor_digest
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.grid import Action

ROW = np.ones((1, 6), dtype=bool)  # one row of six cells: columns 0..5


def drive(lanes, trips, cells=range(6)):
    """Robots driving along the row: each trip a list of columns, one a step."""
    for trip in trips:
        for column in trip:
            lanes.observe(np.array([column]))
        lanes._previous = None  # the next trip starts afresh


def test_a_lane_runs_the_way_most_traffic_goes_and_nowhere_else():
    lanes = TrafficLanes(graph_search.move_graph(ROW), paths=3, period=1, decay=1.0,
                         share=0.7, minimum=2)  # fmt: skip
    drive(lanes, [[0, 1, 2, 3, 4, 5]] * 3 + [[5, 4, 3]])  # east thrice, west once (5..3)
    learned = lanes.lanes()
    assert learned[:3, Action.RIGHT].tolist() == [3, 3, 3]  # only east from cells 0-2
    assert learned[3:5, Action.RIGHT].tolist() == [3, 3]  # 3 east against 1 west: 75 %
    assert (learned[:, [Action.LEFT, Action.UP, Action.DOWN]] == 0).all()
    balanced = TrafficLanes(graph_search.move_graph(ROW), period=1, decay=1.0, minimum=2)
    drive(balanced, [[0, 1, 2, 3, 4, 5], [5, 4, 3, 2, 1, 0]] * 2)
    assert (balanced.lanes()[1:5] == 0).all()  # the ends: every move out of them is one way
    thin = TrafficLanes(graph_search.move_graph(ROW), period=1, decay=1.0, minimum=5)
    drive(thin, [[0, 1, 2, 3, 4, 5]] * 4)
    assert (thin.lanes() == 0).all()


def test_counts_fade_and_the_lanes_come_due_every_period():
    lanes = TrafficLanes(graph_search.move_graph(ROW), period=3, decay=0.5)
    due = [lanes.observe(np.array([c])) for c in (0, 1, 2, 3, 4, 5)]
    assert due == [False, False, True, False, False, True]
    assert lanes.counts[4, Action.RIGHT] == 1.0
    assert lanes.counts[0, Action.RIGHT] == 0.5**4


def test_learned_lanes_are_saved_and_loaded_for_their_floor_only(tmp_path):
    graph = graph_search.move_graph(ROW)
    lanes = TrafficLanes(graph, period=1, decay=1.0)
    drive(lanes, [[0, 1, 2, 3]] * 5)
    lanes.save(tmp_path / "lanes.npz", ROW)
    again = TrafficLanes(graph)
    again.load(tmp_path / "lanes.npz", ROW)
    assert (again.counts == lanes.counts).all()
    other = np.ones((2, 3), dtype=bool)
    assert floor_digest(other) != floor_digest(ROW)
    with pytest.raises(ValueError, match="another floor"):
        TrafficLanes(graph_search.move_graph(other)).load(tmp_path / "lanes.npz", other)
    (tmp_path / "broken.npz").write_bytes(b"not a file of lanes")
    with pytest.raises(ValueError, match="not learned lanes"):
        again.load(tmp_path / "broken.npz", ROW)


def test_settings_out_of_range_are_refused():
    graph = graph_search.move_graph(ROW)
    for bad in ({"paths": 0}, {"period": 0}, {"decay": 0.0}, {"share": 0.4}, {"minimum": 0}):
        with pytest.raises(ValueError, match="paths and period"):
            TrafficLanes(graph, **bad)


@settings(max_examples=25, deadline=None)
@given(
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 14),
    seed=st.integers(0, 2**16),
    floor_lanes=st.integers(0, 3),
)
def test_traffic_grants_every_plan_with_learned_and_floor_lanes(
    rows, cols, shelf_bits, robots, seed, floor_lanes
):
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        env = fleet.parallel_env(num_robots=robots, layout=layout, starts="random",
                                 moves="rotate", on_delivery="new_package",
                                 max_cycles=40)  # fmt: skip
    except ValueError:  # too small for the fleet
        return
    guidance = {"learned_lane_paths": 2, "learn_period": 5, "floor_lane_paths": floor_lanes}
    refused, digest = play(env, planner_policy("guided", seed, **guidance), seed, 40)
    assert refused == 0
    assert play(env, planner_policy("guided", seed, **guidance), seed, 40) == (refused, digest)
