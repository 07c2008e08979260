"""Windowed repair: never a worse plan by its measure, never a refused or conflicting move,
the same plans for a seed, and its bounds honoured."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.planners.test_guidance import play
from tests.world.random_floors import shelf_layout
from warehouse_phys.envs import fleet
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.operation_kernels import _reserve_all
from warehouse_phys.planners.operations import OperationPIBT
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, resolve_turning_moves


def random_fleet(seed, rows=7, cols=9, density=0.15, robots=20):
    """A random floor and a turning fleet on it: grid, cells, goals, headings, free cells."""
    rng = np.random.default_rng(seed)
    layout = ["".join("#" if rng.random() < density else "." for _ in range(cols))
              for _ in range(rows)]  # fmt: skip
    grid = WarehouseGrid.from_layout(layout)
    free = np.argwhere(grid.free_mask)
    n = min(len(free), robots)
    cells = free[rng.choice(len(free), n, replace=False)]
    goals = free[rng.choice(len(free), n)]
    return grid, cells, goals, rng.integers(0, 4, n), free, rng


def reservations_hold(window, plan, chosen):
    """No two robots hold one cell at one depth, and none swap: recounted from scratch."""
    depth = window.depth
    seen = set()
    for i in np.flatnonzero(plan.present):
        prev = plan.here[i]
        for d in range(depth):
            cell = int(plan.cells[i, chosen[i], d])
            if (cell, d) in seen:
                return False
            seen.add((cell, d))
            prev = cell
    moves = {}
    for i in np.flatnonzero(plan.present):
        prev = int(plan.here[i])
        for d in range(depth):
            cell = int(plan.cells[i, chosen[i], d])
            if cell != prev:
                if (cell, prev, d) in moves:
                    return False
                moves[(prev, cell, d)] = i
            prev = cell
    return True


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**16), neighbourhood=st.integers(2, 10), depth=st.integers(1, 4),
       corner_follows=st.booleans(), time_limit=st.sampled_from([None, 0.0, 1e-4]))  # fmt: skip
def test_the_repair_never_makes_a_plan_worse_nor_lets_robots_meet(
    seed, neighbourhood, depth, corner_follows, time_limit
):
    """On random floors, a one-step PIBT plan repaired: the plan's value (the sum of its
    operations' values) never grows, the repaired reservations keep every two robots apart
    at every step of the window, and traffic grants every first action; also when the
    repair's time runs out part way (or at once)."""
    grid, cells, goals, headings, free, rng = random_fleet(seed)
    pibt = PIBT(grid, seed=seed, moves="rotate", corner_follows=corner_follows)
    window = OperationPIBT(grid, seed=seed, depth=depth, corner_follows=corner_follows)
    repair = WindowRepair(neighbourhood=neighbourhood, iterations=500, seed=seed,
                          time_limit=time_limit)  # fmt: skip
    for _ in range(12):
        actions = pibt.plan(cells, goals, headings=headings)
        plan = window._prepare(cells, goals, None, None, headings, None)
        waits = (3,) * (depth - 1)
        chosen = np.array([window._index[(int(a), *waits)] for a in actions])
        _reserve_all(np.arange(len(cells)), chosen, plan.here, plan.cells, plan.heads,
                     HEADING_MOVES, plan.at, plan.leaving)  # fmt: skip
        assert reservations_hold(window, plan, chosen)
        repair.improve(plan.movable, plan.here, plan.ranked, plan.values, plan.cells, plan.heads,
                       HEADING_MOVES, plan.at, plan.leaving, plan.standing, chosen,
                       corner_follows)  # fmt: skip
        assert repair.stats.value_after <= repair.stats.value_before + 1e-9
        assert reservations_hold(window, plan, chosen)
        again = WindowRepair(neighbourhood=neighbourhood, seed=seed, time_limit=time_limit)
        repaired = window.improve(cells, goals, headings=headings, actions=actions, repair=again)
        cells, headings, refused = resolve_turning_moves(grid, cells, headings, repaired,
                                                         corner_follows=corner_follows)  # fmt: skip
        assert not refused.any()
        pibt.forget_commitments(np.arange(len(cells)))
        arrived = (cells == goals).all(axis=1)
        goals[arrived] = free[rng.choice(len(free), int(arrived.sum()))]


@settings(max_examples=25, deadline=None)
@given(
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 14),
    seed=st.integers(0, 2**16),
    name=st.sampled_from(["guided-repair", "guided-ops-repair"]),
    lifelong=st.booleans(),
)
def test_traffic_grants_every_repaired_plan_on_any_floor(
    rows, cols, shelf_bits, robots, seed, name, lifelong
):
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        env = fleet.parallel_env(num_robots=robots, layout=layout, starts="random",
                                 moves="rotate", on_delivery="new_package" if lifelong else "park",
                                 max_cycles=30)  # fmt: skip
    except ValueError:  # too small for the fleet
        return
    policy = planner_policy(name, seed, neighbourhood=4)
    refused, _ = play(env, policy, seed, 30)
    assert refused == 0
    planner = policy.planner
    if planner is not None and planner.repair is not None:
        assert not planner.repair.stats.fell_back
    elif planner is not None:  # over operations, handed over to PIBT when the fleet stalled
        assert planner.stall_watch.stalled


def test_the_repair_is_the_same_for_a_seed_and_differs_for_another():
    env = fleet.parallel_env(num_robots=48, layout="warehouse", lifelong=True, max_cycles=40,
                             moves="rotate")  # fmt: skip
    first = play(env, planner_policy("guided-repair", 1), 1, 40)
    assert play(env, planner_policy("guided-repair", 1), 1, 40) == first
    assert play(env, planner_policy("guided-repair", 2), 1, 40) != first


def test_a_repair_with_no_iterations_or_no_time_leaves_the_plan_as_it_was():
    grid, cells, goals, headings, _, _ = random_fleet(3, robots=30)
    pibt = PIBT(grid, seed=0, moves="rotate")
    actions = pibt.plan(cells, goals, headings=headings)
    window = OperationPIBT(grid, seed=0)
    past = WindowRepair()
    past.deadline = 0.0  # an instant long gone (a planner's bound on its step)
    for repair in (WindowRepair(iterations=0), WindowRepair(time_limit=0.0), past):
        kept = window.improve(cells, goals, headings=headings, actions=actions, repair=repair)
        assert kept.tolist() == actions.tolist()
        assert repair.stats.kept == 0
    assert past.stats.tried == 0
    past.deadline = None  # no bound: it searches
    window.improve(cells, goals, headings=headings, actions=actions, repair=past)
    assert past.stats.tried > 0


def test_bounds_out_of_range_are_refused():
    for bad in ({"neighbourhood": 1}, {"iterations": -1}, {"time_limit": -1.0}):
        with pytest.raises(ValueError, match="neighbourhood"):
            WindowRepair(**bad)
    grid = WarehouseGrid.from_layout(["...."])
    with pytest.raises(ValueError, match="turning robots"):
        GuidedPIBT(grid, repair=WindowRepair())
