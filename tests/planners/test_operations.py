"""PIBT over multi-action operations for turning robots (EPIBT)."""

import itertools
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import ROOT
from tests.planners.test_guidance import TWO_AISLES, play
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import fleet
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.operations import OperationPIBT, local_offsets, operation_table
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import TurnAction, resolve_turning_moves


def test_the_operations_are_every_sequence_but_a_turn_straight_back():
    ops = operation_table(3)
    assert ops.shape == (50, 3)  # 64 less 14 with a clockwise turn next to a counter one
    assert ops[0].tolist() == [TurnAction.WAIT] * 3
    assert len({tuple(op) for op in ops.tolist()}) == len(ops)
    for op in ops.tolist():
        for a, b in itertools.pairwise(op):
            assert {a, b} != {TurnAction.CLOCKWISE, TurnAction.COUNTERCLOCKWISE}
    assert operation_table(1).tolist() == [[3], [0], [1], [2]]
    assert len(local_offsets(3)) == 41  # the cells within 4 moves


@settings(max_examples=40, deadline=None)
@given(
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 14),
    seed=st.integers(0, 2**16),
    corner_follows=st.booleans(),
    lifelong=st.booleans(),
)
def test_traffic_grants_every_plan_over_operations_on_any_floor(
    rows, cols, shelf_bits, robots, seed, corner_follows, lifelong
):
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        env = fleet.parallel_env(
            num_robots=robots, layout=layout, starts="random", moves="rotate",
            on_delivery="new_package" if lifelong else "park", max_cycles=30,
            **({} if corner_follows else {"robot_radius": 0.34}),
        )  # fmt: skip
    except ValueError:  # too small for the fleet
        return
    policy = planner_policy("guided-ops", seed, refresh=2)
    refused, _ = play(env, policy, seed, 30)
    assert refused == 0
    planner = policy.planner
    if planner is not None and planner.operations is not None:
        assert planner.operations.refused == 0  # the reservations alone kept robots apart
    elif planner is not None:  # handed over to one-step PIBT when the fleet stalled
        assert planner.stall_watch.stalled


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), depth=st.integers(1, 4), revisits=st.integers(1, 3),
       corner_follows=st.booleans())  # fmt: skip
def test_every_plan_keeps_robots_apart_and_no_robot_refused(seed, depth, revisits, corner_follows):
    """A dense random floor, robots planned without guidance, moved by the traffic rule:
    no move is ever refused (so no two robots meet or swap)."""
    rng = np.random.default_rng(seed)
    rows = ["".join("#" if rng.random() < 0.15 else "." for _ in range(9)) for _ in range(7)]
    try:
        grid = WarehouseGrid.from_layout(rows)
    except ValueError:
        return
    free = np.argwhere(grid.free_mask)
    n = min(len(free), 20)
    cells = free[rng.choice(len(free), n, replace=False)]
    goals = free[rng.choice(len(free), n)]
    headings = rng.integers(0, 4, n)
    planner = OperationPIBT(grid, seed=seed, depth=depth, revisits=revisits,
                            corner_follows=corner_follows)  # fmt: skip
    for _ in range(20):
        actions = planner.plan(cells, goals, headings=headings)
        assert planner.refused == 0  # the reservations alone kept the robots apart
        cells, headings, refused = resolve_turning_moves(grid, cells, headings, actions,
                                                         corner_follows=corner_follows)  # fmt: skip
        assert not refused.any()
        arrived = (cells == goals).all(axis=1)
        goals[arrived] = free[rng.choice(len(free), int(arrived.sum()))]


def test_a_robot_turns_and_drives_round_a_corner_to_its_goal():
    """One robot facing east at the top left of the two-aisle floor, its goal at the bottom
    left: it turns south and drives down, the shortest way (2 moves, 1 turn)."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    planner = OperationPIBT(grid, seed=0)
    cells, headings, goals = np.array([(0, 0)]), np.array([0]), np.array([(2, 0)])
    seen = []
    while not (cells == goals).all():
        actions = planner.plan(cells, goals, headings=headings)
        cells, headings, _ = resolve_turning_moves(grid, cells, headings, actions)
        seen.append(int(actions[0]))
    assert seen == [TurnAction.CLOCKWISE, TurnAction.FORWARD, TurnAction.FORWARD]


def test_golden_plans_over_operations_on_the_two_aisle_floor():
    """The four robots of the guided planner's golden turning case without lanes, planned
    over operations with the guidance, recorded: each pair drives its own aisle; robot_1 waits
    for robot_0 to clear the top right corner, then turns down to its goal; robot_3 steps
    up the left column out of robot_2's way, ending where the one-step planner's does."""
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    cells = np.array([(0, 0), (0, 1), (2, 7), (2, 6)])
    goals = np.array([(0, 7), (2, 7), (0, 0), (2, 0)])
    headings = np.array([0, 0, 2, 2])  # east, east, west, west
    config = GuidanceConfig(turn_lane_paths=0)
    planner = GuidedPIBT(grid, seed=0, moves="rotate", operations=3, config=config)
    seen = []
    for _ in range(len(GOLDEN_OPERATIONS_TWO_AISLES)):
        actions = planner.plan(cells, goals, headings=headings)
        cells, headings, refused = resolve_turning_moves(grid, cells, headings, actions)
        assert not refused.any()
        seen.append(actions.tolist())
    assert seen == GOLDEN_OPERATIONS_TWO_AISLES
    assert cells.tolist() == [[0, 7], [2, 7], [0, 0], [0, 1]]


#: The actions of :func:`test_golden_plans_over_operations_on_the_two_aisle_floor`.
GOLDEN_OPERATIONS_TWO_AISLES = [
    [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [3, 0, 0, 0],
    [0, 1, 3, 1], [0, 0, 0, 0], [3, 0, 1, 0], [3, 3, 0, 1], [3, 3, 0, 0],
]  # fmt: skip


def test_runs_over_operations_are_the_same_in_another_process():
    env = fleet.parallel_env(num_robots=24, layout="warehouse", moves="rotate", lifelong=True,
                             max_cycles=40)  # fmt: skip
    _, here = play(env, planner_policy("guided-ops", 3), 3, 40)
    code = (
        "from tests.planners.test_guidance import play\n"
        "from warehouse_phys.envs import fleet\n"
        "from warehouse_phys.rl.fleet_planners import planner_policy\n"
        "env = fleet.parallel_env(num_robots=24, layout='warehouse', moves='rotate',"
        " lifelong=True, max_cycles=40)\n"
        "print(play(env, planner_policy('guided-ops', 3), 3, 40)[1])\n"
    )
    there = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout.strip()  # fmt: skip
    assert there == here


def test_operations_are_refused_for_four_direction_robots_and_out_of_range():
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    with pytest.raises(ValueError, match="turning robots"):
        GuidedPIBT(grid, operations=3)
    with pytest.raises(ValueError, match="depth"):
        OperationPIBT(grid, depth=5)
    with pytest.raises(ValueError, match="revisits"):
        OperationPIBT(grid, revisits=0)


@pytest.mark.parametrize("headings", [None, [0], [0, 4], [[0, 1]], [-1, 0]])
def test_headings_that_are_not_one_of_0_to_3_a_robot_are_refused(headings):
    grid = WarehouseGrid.from_layout(TWO_AISLES)
    planner = OperationPIBT(grid)
    with pytest.raises(ValueError, match="heading"):
        planner.plan(np.array([(0, 0), (2, 0)]), np.array([(0, 7), (2, 7)]), headings=headings)
