"""Traffic guidance: guide paths go round each other's traffic, turning robots' paths turn
little and keep to the one-way lanes, and a bad facing is refused with nothing changed."""

import itertools

import numpy as np
import pytest

from warehouse_phys.planners import traffic_flow
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.traffic_guidance import TrafficGuidance
from warehouse_phys.world.grid import WarehouseGrid

#: Two aisles joined at both ends: a robot each way has a lane of its own.
TWO_AISLES = ["........", ".######.", "........"]


def test_robots_heading_opposite_ways_get_aisles_of_their_own():
    """Two robots cross the two-aisle floor in opposite directions: the second's guide
    path takes the other aisle (the first's would cost it contraflow), where shortest
    paths share the top one."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    here = np.array([0 * 8 + 0, 0 * 8 + 7])
    goal = np.array([0 * 8 + 7, 0 * 8 + 0])
    # One search at a time, so that the second sees the first's path (whatever the first
    # step's batches: first_search_batch).
    priced = GuidanceConfig(first_search_batch=None)
    unpriced = GuidanceConfig(contraflow_weight=0, first_search_batch=None)
    for config, apart in ((priced, True), (unpriced, False)):
        guidance = TrafficGuidance(grid, config)
        guidance.update(here, goal, np.ones(2, dtype=bool))
        paths = guidance._paths
        rows = [guidance._cell_row[paths.pool[paths.start[i] : paths.start[i] + paths.moves[i]
                                              + 1]] for i in range(2)]  # fmt: skip
        assert rows[0].max() == 0  # the first takes the shortest, along the top
        assert (rows[1].max() == 2) == apart


@pytest.mark.parametrize(
    ("turn_contraflow_weight", "facing", "apart"),
    [(2.0, [2, 0], True), (None, [2, 0], False), (2.0, None, False)],
)
def test_contraflow_costs_turning_robots_more(turn_contraflow_weight, facing, apart):
    """The same crossing, with contraflow at a tenth of a move: a four-direction robot's guide
    path shares the top aisle, and so does a turning robot's priced as one's; with a
    turning robot's own weight (``turn_contraflow_weight``, 2 by default) the second
    takes the bottom aisle, turns and all, rather than meet the first head-on."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    config = GuidanceConfig(contraflow_weight=0.1, turn_contraflow_weight=turn_contraflow_weight,
                            turn_lane_paths=0, first_search_batch=None)  # fmt: skip
    guidance = TrafficGuidance(grid, config)
    guidance.update(np.array([0, 7]), np.array([7, 0]), np.ones(2, dtype=bool),
                    facing=None if facing is None else np.array(facing))  # fmt: skip
    paths = guidance._paths
    rows = guidance._cell_row[paths.pool[paths.start[1] : paths.start[1] + paths.moves[1] + 1]]
    assert (rows.max() == 2) == apart


@pytest.mark.parametrize(
    ("lane_paths", "facing", "kept_to_the_lanes"),
    [(2, [2], True), (1, [2], True), (0, [2], False), (2, None, False)],
)
def test_turning_robots_keep_to_the_one_way_lanes(lane_paths, facing, kept_to_the_lanes):
    """On the two-aisle floor the lanes run west along the top aisle, south, east along the
    bottom and north (:func:`~warehouse_phys.planners.lanes.one_way_lanes`). A turning robot
    crossing from the top left to the top right goes round by the bottom aisle, 11 moves
    and 3 turns, rather than drive 7 moves against the top aisle's lane; without lanes, or
    as a four-direction robot (whose guidance lays none), it takes the top aisle. Its
    flow holds the lanes' phantom paths besides its own path."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    guidance = TrafficGuidance(grid, GuidanceConfig(turn_lane_paths=lane_paths))
    facing = None if facing is None else np.array(facing)
    guidance.update(np.array([0]), np.array([7]), np.ones(1, dtype=bool), facing=facing)
    paths = guidance._paths
    cells = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1]
    assert (guidance._cell_row[cells].max() == 2) == kept_to_the_lanes
    assert paths.moves[0] == (11 if kept_to_the_lanes else 7)
    lanes = 0 if facing is None else lane_paths * 14  # 6 + 6 aisle cells, 2 at the ends
    assert guidance.flow.sum() == lanes + paths.moves[0]
    guidance.update(np.array([0]), np.array([7]), np.ones(1, dtype=bool), facing=facing)
    assert guidance.flow.sum() == lanes + paths.moves[0]  # laid once


def guide_path_turns(facing, turn_cost):
    """The guide path of one robot facing move ``facing`` across an open 7 x 7 floor,
    corner to corner, and how many quarter turns driving it takes."""
    grid = WarehouseGrid.from_layout(["......."] * 7)
    guidance = TrafficGuidance(grid, GuidanceConfig(turn_cost=turn_cost))
    guidance.update(np.array([0]), np.array([48]), np.ones(1, dtype=bool), facing=facing)
    paths = guidance._paths
    cells = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1]
    moves = [traffic_flow._move_of(guidance._graph, a, b) for a, b in itertools.pairwise(cells)]
    turns = sum(1 for a, b in itertools.pairwise([int(facing[0]), *moves]) if a != b)
    return len(moves), turns


@pytest.mark.parametrize("facing", [0, 1, 2, 3])  # left, down, right, up
def test_a_turning_robots_guide_path_turns_as_little_as_it_can(facing):
    """Every shortest path across an open floor is as cheap to a four-direction robot;
    a turning robot's guide path is still shortest, and turns the fewest times from the
    way it faces: once when it faces down or right, twice when it faces away."""
    moves, turns = guide_path_turns(np.array([facing]), 1.0)
    assert moves == 12
    assert turns == (1 if facing in (1, 2) else 2)
    if facing == 2:  # searched as a four-direction robot's, it goes down first
        assert guide_path_turns(np.array([facing]), None) == (12, 2)


@pytest.mark.parametrize(("weight", "turns_at_the_corner"), [(0.0, True), (1.0, False)])
def test_a_turn_where_guide_paths_pass_is_priced_by_their_traffic(weight, turns_at_the_corner):
    """A robot facing right across an open 5 x 5 floor turns once, at the top right
    corner; with ten guide paths leaving that corner and ``turn_traffic_weight=1`` a turn
    there costs 11, and the robot turns twice elsewhere instead (moves stay free of the
    traffic: vertex and contraflow weights 0)."""
    grid = WarehouseGrid.from_layout(["....."] * 5)
    config = GuidanceConfig(vertex_weight=0.0, contraflow_weight=0.0,
                            turn_traffic_weight=weight)  # fmt: skip
    guidance = TrafficGuidance(grid, config)
    guidance.flow[4, 1] = 10  # ten guide paths leave the corner (0, 4) downwards
    guidance.update(np.array([0]), np.array([24]), np.ones(1, dtype=bool), facing=np.array([2]))
    paths = guidance._paths
    cells = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1].tolist()
    assert len(cells) == 9  # a shortest path either way
    moves = [traffic_flow._move_of(guidance._graph, a, b) for a, b in itertools.pairwise(cells)]
    turned_at = [cells[j] for j in range(1, len(moves)) if moves[j] != moves[j - 1]]
    assert (turned_at == [4]) == turns_at_the_corner
    assert len(turned_at) == (1 if turns_at_the_corner else 2)


@pytest.mark.parametrize("facing", [np.array([4]), np.array([-1]), np.array([0, 1])])
def test_a_facing_that_is_not_one_move_a_robot_is_refused_and_nothing_changes(facing):
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    guidance = TrafficGuidance(grid, GuidanceConfig(turn_lane_paths=0))
    with pytest.raises(ValueError, match="facing"):
        guidance.update(np.array([0]), np.array([7]), np.ones(1, dtype=bool), facing=facing)
    assert not guidance.flow.any()
    guidance.update(np.array([0]), np.array([7]), np.ones(1, dtype=bool), facing=np.array([2]))
    assert guidance.flow.sum() == 7


#: Two aisles 16 cells long, joined at both ends.
LONG_AISLES = ["................", ".##############.", "................"]


@pytest.mark.parametrize(
    ("reroute", "kept_to_the_top"), [(0, False), (2, True), (6, False), (7, False)]
)
def test_a_robot_pushed_off_a_long_path_searches_only_so_far_with_reroute(reroute, kept_to_the_top):
    """A robot's guide path runs east along the top aisle; traffic then comes the other
    way along it, and the robot is pushed back off its path. A new search to the goal
    takes the bottom aisle. With ``reroute=2`` it searches only to the path's cell two
    past where it stood, and keeps the top aisle from there. With 6 that search itself
    goes round by the bottom aisle and meets the old path at the goal: the path leaves
    it there (no cell twice, no way back along the top); with 7 the path has no more than
    twice that many cells left, and is searched anew."""
    grid = WarehouseGrid.from_layout(LONG_AISLES)
    guidance = TrafficGuidance(grid, GuidanceConfig(reroute=reroute))
    goal, active = np.array([15]), np.ones(1, dtype=bool)
    guidance.update(np.array([2]), goal, active)
    paths = guidance._paths
    first = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1].copy()
    assert guidance._cell_row[first].max() == 0  # along the top
    guidance.flow[guidance._column[np.arange(1, 16)], 0] += 5  # traffic going west on top
    guidance.update(np.array([0]), goal, active)
    assert guidance.searches == 1
    cells = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1]
    assert cells[0] == guidance._column[0]
    assert cells[-1] == guidance._column[15]
    assert len(set(cells.tolist())) == len(cells)
    assert (guidance._cell_row[cells].max() == 0) == kept_to_the_top
    if kept_to_the_top:
        np.testing.assert_array_equal(cells[-(len(first) - reroute) :], first[reroute:])


def test_a_refreshed_guide_path_is_searched_whole_with_reroute():
    """``refresh`` searches a robot's whole path anew, ``reroute`` or not: a robot still
    on its path along the top aisle, traffic then coming the other way along it, is
    refreshed onto the bottom aisle."""
    grid = WarehouseGrid.from_layout(LONG_AISLES)
    guidance = TrafficGuidance(grid, GuidanceConfig(reroute=2, refresh=1))
    goal, active = np.array([15]), np.ones(1, dtype=bool)
    guidance.update(np.array([2]), goal, active)
    guidance.flow[guidance._column[np.arange(1, 16)], 0] += 5  # traffic going west on top
    guidance.update(np.array([2]), goal, active)
    assert guidance.searches == 1
    paths = guidance._paths
    cells = paths.pool[paths.start[0] : paths.start[0] + paths.moves[0] + 1]
    assert guidance._cell_row[cells].max() == 2


def test_later_steps_keep_to_their_own_search_count_and_start_with_the_robots_left():
    """``later_max_searches=20``: the first step searches all 30 robots' first guide
    paths, each later step at most 20. When every robot gets a new goal twice over, the
    second step leaves 10 unguided (``timed_out``), and the third searches those 10
    before any other, so no robot goes two steps without a guide path."""
    grid = WarehouseGrid(12, 12)
    here = np.arange(30) * 4  # cells 0, 4, ..., 116: robots standing still
    active = np.ones(30, dtype=bool)
    guidance = TrafficGuidance(grid, GuidanceConfig(later_max_searches=20))
    guidance.update(here, here + 24, active)
    assert (guidance.searches, guidance.timed_out) == (30, 0)
    guidance.update(here, here + 25, active)  # every robot a new goal: 30 searches needed
    assert (guidance.searches, guidance.timed_out) == (20, 10)
    left = np.flatnonzero(~guidance._guided)
    assert len(left) == 10
    guidance.update(here, here + 26, active)  # and again
    assert (guidance.searches, guidance.timed_out) == (20, 10)
    assert guidance._guided[left].all()


def test_later_steps_stop_searching_once_their_searches_have_expanded_the_bound():
    """``later_max_expanded``: the first step searches every robot whatever the bound; a
    later step begins no search once its searches have expanded the bound's cells, so a
    bound of one cell lets one search a step, and a bound above a step's work lets all."""
    grid = WarehouseGrid(12, 12)
    here = np.arange(30) * 4
    active = np.ones(30, dtype=bool)
    steps = {}
    for bound in (1, 10**9):
        guidance = TrafficGuidance(grid, GuidanceConfig(later_max_expanded=bound))
        guidance.update(here, here + 24, active)
        assert (guidance.searches, guidance.timed_out) == (30, 0)
        assert guidance.expanded >= 30
        guidance.update(here, here + 25, active)
        steps[bound] = (guidance.searches, guidance.timed_out, guidance.expanded)
        searched = np.flatnonzero(guidance._guided)
        guidance.update(here, here + 25, active)  # the same goals: the others still need one
        if bound == 1:  # the robot searched keeps its path, and one more is searched
            assert guidance._guided[searched].all()
            assert guidance._guided.sum() == 2
    assert steps[1][:2] == (1, 29)
    assert steps[10**9][:2] == (30, 0)
    assert steps[1][2] < steps[10**9][2]
