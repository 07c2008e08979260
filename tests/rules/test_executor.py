"""The executor: PIBT plans run tick by tick under delays, never a conflict, never stuck,
lock step when nothing is late; the graph joined to moves in progress; its measures."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.rules.async_grid import AsyncGrid, swap_conflicts, vertex_conflicts
from warehouse_phys.rules.executor import Executor, pibt_window
from warehouse_phys.rules.grid import WarehouseGrid
from warehouse_phys.rules.planning import PIBT


def random_fleet(rows, cols, shelf_bits, robots, seed):
    """A floor with shelves from ``shelf_bits``, up to ``robots`` robots on distinct
    reachable cells and goals on reachable cells; ``None`` when the floor has no room."""
    cells = [["#" if (shelf_bits >> (r * 7 + c)) & 1 and (r + c) % 3 else "."
              for c in range(cols)] for r in range(rows)]  # fmt: skip
    cells[0][0] = "S"
    try:
        grid = WarehouseGrid.from_layout(["".join(row) for row in cells])
    except ValueError:  # no room for a package
        return None
    room = np.argwhere(grid.reachable_mask)
    robots = min(robots, len(room) - 1)  # (the fullest floors leave one cell free)
    if robots < 1:
        return None
    rng = np.random.default_rng(seed)
    starts = room[rng.choice(len(room), robots, replace=False)]
    goals = room[rng.choice(len(room), robots)]
    return grid, starts, goals


def run(grid, starts, goals, needed, *, seed, p_delay, ticks, plan_every, window, stop_at):
    """Execute PIBT windows under random delays (until tick ``stop_at``) against the grid
    twin, checking every tick; returns the executor, the tick of the last plan and every
    tick's report."""
    slow = (np.asarray(needed) > 1).any()
    planner = PIBT(grid, corner_follows=not slow, seed=seed)
    executor = Executor(grid, starts, needed)
    world = AsyncGrid(grid, executor.held()[:, 0], needed)
    rng = np.random.default_rng(seed + 1)
    reports, last_plan = [], 0
    for tick in range(ticks):
        if tick % plan_every == 0 and tick <= stop_at:
            executor.add_plan(pibt_window(planner, executor.plan_cells(), goals, window))
            last_plan = tick
        delayed = (rng.random(len(starts)) < p_delay) & (tick < stop_at)
        before = world.held()
        report = executor.step(delayed)
        ended = world.step(report.go, report.heading, delayed)
        assert (ended == report.ended).all()
        assert (world.held() == executor.held()).all()
        assert vertex_conflicts(world.held()).size == 0, f"tick {tick}"
        assert swap_conflicts(before, world.held()) == 0, f"tick {tick}"
        reports.append(report)
    return executor, last_plan, reports


fleets = st.builds(
    random_fleet,
    rows=st.integers(2, 7),
    cols=st.integers(2, 7),
    shelf_bits=st.integers(0, 2**49 - 1),
    robots=st.integers(1, 14),
    seed=st.integers(0, 2**16),
)


@given(
    fleet=fleets,
    seed=st.integers(0, 2**16),
    slow=st.booleans(),
    p_delay=st.sampled_from([0.0, 0.05, 0.3, 0.8]),
    plan_every=st.integers(1, 6),
    window=st.integers(1, 6),
)
def test_no_conflict_whatever_the_delays_and_every_window_completes(
    fleet, seed, slow, p_delay, plan_every, window
):
    """Vertex and swap conflicts are checked every tick by the grid twin (in ``run``);
    once delays end, the last window completes within its last release plus the ticks
    of all its moves (the no-deadlock bound of the module)."""
    if fleet is None:
        return
    grid, starts, goals = fleet
    needed = np.random.default_rng(seed).integers(1, 4, len(starts)) if slow else 1
    stop_at = 30
    executor, last_plan, _ = run(
        grid, starts, goals, needed, seed=seed, p_delay=p_delay, ticks=stop_at + 1,
        plan_every=plan_every, window=window, stop_at=stop_at,
    )  # fmt: skip
    ticks_needed = executor.ticks_needed
    last_release = last_plan + ticks_needed.max() * (window + 1)
    bound = max(executor.tick, last_release) + int(ticks_needed.sum()) * (window + 1)
    world = AsyncGrid(grid, executor.left, ticks_needed)
    world.entered[:], world.done[:] = executor.entered, executor.done
    while not executor.window_done() or executor.done.any():
        assert executor.tick <= bound, "the window did not complete: deadlock"
        before = executor.held()
        report = executor.step()
        world.step(report.go, report.heading)
        assert vertex_conflicts(world.held()).size == 0
        assert swap_conflicts(before, world.held()) == 0
    assert (executor.drift() == 0).all()


@given(
    fleet=fleets,
    seed=st.integers(0, 2**16),
    plan_every=st.integers(1, 5),
    window=st.integers(1, 6),
    corner_follows=st.booleans(),
)
def test_without_delays_one_tick_moves_are_the_lock_step_plan(
    fleet, seed, plan_every, window, corner_follows
):
    """Rotations and follows (corner follows too) included: at tick ``t0 + s`` every
    robot stands where the plan given at ``t0`` puts it at step ``s``."""
    if fleet is None:
        return
    grid, starts, goals = fleet
    planner = PIBT(grid, corner_follows=corner_follows, seed=seed)
    executor = Executor(grid, starts, 1)
    for tick in range(24):
        if tick % plan_every == 0:
            path = pibt_window(planner, executor.plan_cells(), goals, window)
            executor.add_plan(path)
            given_at = tick
        report = executor.step()
        step = min(tick + 1 - given_at, window)
        expected = path[:, step, 0] * grid.cols + path[:, step, 1]
        assert (executor.left == expected).all()
        assert (executor.entered == expected).all()
        assert not (report.knock_on | report.own_delay).any()
        assert (executor.drift() == 0).all()


def corridor(robots, needed):
    """An executor of ``robots`` in a line on row 0, robot 0 at its right end."""
    grid = WarehouseGrid.from_layout(["S" + "." * 9, "." * 10])
    cells = np.array([(0, robots - 1 - i) for i in range(robots)])
    return Executor(grid, cells, needed)


def straight_path(executor, steps):
    start = executor.plan_cells()
    return np.stack([start + np.array([0, s]) for s in range(steps + 1)], axis=1)


def test_a_follower_goes_on_the_tick_its_leaders_move_ends():
    executor = corridor(2, [3, 2])
    executor.add_plan(straight_path(executor, 1))
    heads = []
    for _ in range(4):
        report = executor.step()
        heads.append((report.go.tolist(), executor.done.tolist()))
    # Robot 0 takes ticks 0-2; robot 1 starts in tick 2, as robot 0 leaves, and takes 2.
    assert heads == [([True, False], [1, 0]), ([True, False], [2, 0]),
                     ([True, True], [0, 1]), ([False, True], [0, 0])]  # fmt: skip
    assert executor.window_done()


def test_own_delays_knock_on_delays_and_drift():
    executor = corridor(3, 1)
    executor.add_plan(straight_path(executor, 4))
    delayed = np.array([True, False, False])
    reports = [executor.step(delayed), executor.step(delayed), executor.step()]
    assert [r.own_delay.tolist() for r in reports[:2]] == [[True, False, False]] * 2
    # Robots 1 and 2 follow robot 0 and stand still because of it: knock-on.
    assert [r.knock_on.tolist() for r in reports[:2]] == [[False, True, True]] * 2
    assert not (reports[2].own_delay | reports[2].knock_on).any()
    assert executor.drift().tolist() == [2, 2, 2]
    assert executor.plan_cells()[:, 1].tolist() == [3, 2, 1]


def test_a_planned_wait_is_skipped_by_a_robot_behind_its_plan():
    grid = WarehouseGrid.from_layout(["S...."])
    executor = Executor(grid, [(0, 0)], 1)
    executor.add_plan(np.array([[(0, 0), (0, 1), (0, 1), (0, 1), (0, 2)]]))
    executor.step(np.array([True]))
    executor.step(np.array([True]))
    assert executor.drift().tolist() == [2]
    executor.step()  # move 1 (released at tick 0)
    assert executor.drift().tolist() == [0]  # move 2 is released at tick 3: on time again
    executor.step()
    assert executor.left.tolist() == [2]


def test_a_new_plan_joins_the_moves_in_progress():
    """The robot in mid-move plans from the cell it enters; the robot planned into the
    cell it leaves waits for its move to end."""
    executor = corridor(2, 3)
    executor.add_plan(straight_path(executor, 3))
    executor.step()
    assert executor.done.tolist() == [1, 0]
    assert executor.plan_cells().tolist() == [[0, 2], [0, 0]]
    executor.add_plan(straight_path(executor, 2))
    goes = [executor.step().go.tolist() for _ in range(3)]
    assert goes == [[True, False], [True, True], [True, True]]
    assert executor.held().tolist() == [[2, 3], [0, 1]]
    assert executor.drift().tolist() == [0, 1]


def test_a_rotation_of_one_tick_moves_goes_in_one_tick():
    grid = WarehouseGrid.from_layout(["S.", ".."])
    cells = np.array([(0, 0), (0, 1), (1, 1), (1, 0)])
    executor = Executor(grid, cells, 1)
    turned = cells[[1, 2, 3, 0]]
    executor.add_plan(np.stack([cells, turned], axis=1))
    assert not executor.step(np.array([False, False, True, False])).go.any()
    assert executor.step().advanced.all()
    assert (executor.plan_cells() == turned).all()


def test_plans_that_cannot_be_executed_are_refused_in_one_line():
    grid = WarehouseGrid.from_layout(["S.", ".."])
    cells = np.array([(0, 0), (0, 1), (1, 1), (1, 0)])
    executor = Executor(grid, cells, [1, 2, 1, 1])
    turned = cells[[1, 2, 3, 0]]
    cases = {
        "rotates robot 1": np.stack([cells, turned], axis=1),
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


def test_delays_must_be_one_flag_a_robot():
    executor = corridor(2, 1)
    with pytest.raises(ValueError, match="delayed"):
        executor.step(np.array([1, 0]))
