"""The executor: PIBT plans run tick by tick under delays, never a conflict, never stuck,
lock step when nothing is late; the graph joined to moves in progress; its measures."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.world.random_floors import shelf_layout
from warehouse_phys.execution.async_grid import AsyncGrid, gap_conflicts, swap_conflicts
from warehouse_phys.execution.executor import Executor
from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.execution.windows import pibt_window
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid


def random_fleet(rows, cols, shelf_bits, robots, seed):
    """A floor with shelves from ``shelf_bits``, up to ``robots`` robots on distinct
    reachable cells and goals on reachable cells; ``None`` when the floor has no room."""
    layout = shelf_layout(rows, cols, shelf_bits)
    try:
        grid = WarehouseGrid.from_layout(layout)
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


def closest_by_sampling(before, after, samples=33):
    """The least distance between any two centres moving linearly from ``before`` to
    ``after`` (``(N, 2)``), by brute force over every pair and ``samples`` instants."""
    t = np.linspace(0.0, 1.0, samples)[:, None, None]
    at = before[None] + t * (after - before)[None]  # (samples, N, 2)
    gaps = np.linalg.norm(at[:, :, None, :] - at[:, None, :, :], axis=-1)
    gaps[:, np.arange(len(before)), np.arange(len(before))] = np.inf
    return gaps.min(initial=np.inf)


def check_tick(world, executor, before, report, delayed, tick):
    """Step the grid twin under the tick's commands and check it against the executor:
    the same cells, no swap, no two centres closer than the executor's gap all tick
    (:func:`gap_conflicts`, and by brute force)."""
    held, centres = world.held(), world.centres()
    ended = world.step(report.go, report.heading, delayed, report.facing)
    assert (ended == report.ended).all()
    assert (world.held() == executor.held()).all()
    if executor.headings is not None:  # turning robots: the same headings too
        assert (world.headings == executor.headings).all()
        assert (world.facing == executor.facing).all()
    assert gap_conflicts((held, world.held()), (centres, world.centres()), executor.min_gap) == 0
    assert closest_by_sampling(centres, world.centres()) >= executor.min_gap - 1e-9, tick
    assert swap_conflicts(before, world.held()) == 0, f"tick {tick}"
    # One robot at a time leaves a cell, one enters it, and a robot at rest holds it alone.
    n = len(world.left)
    assert np.unique(world.left).size == n, tick
    assert np.unique(world.entered).size == n, tick


def run(
    grid, starts, goals, needed, *, seed, p_delay, ticks, plan_every, window, stop_at,
    min_gap=DEFAULT_MIN_GAP, headings=None,
):  # fmt: skip
    """Execute PIBT windows under random delays (until tick ``stop_at``) against the grid
    twin, checking every tick; returns the executor, the tick of the last plan and every
    tick's report. ``headings``: turning robots (PIBT over cells and headings)."""
    each = np.broadcast_to(np.asarray(needed), len(starts))
    rotations = bool((each == each[0]).all()) and min_gap <= DEFAULT_MIN_GAP
    planner = PIBT(grid, moves="grid" if headings is None else "rotate", seed=seed)
    executor = Executor(grid, starts, needed, min_gap, headings)
    world = AsyncGrid(grid, executor.held()[:, 0], needed, headings)
    rng = np.random.default_rng(seed + 1)
    reports, last_plan = [], 0
    for tick in range(ticks):
        if tick % plan_every == 0 and tick <= stop_at:
            path = pibt_window(planner, executor.plan_cells(), goals, window,
                               headings=executor.plan_headings(), rotations=rotations)  # fmt: skip
            executor.add_plan(path)
            last_plan = tick
        delayed = (rng.random(len(starts)) < p_delay) & (tick < stop_at)
        before = world.held()
        report = executor.step(delayed)
        check_tick(world, executor, before, report, delayed, tick)
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
    slow=st.sampled_from(["one tick", "same ticks", "mixed ticks"]),
    p_delay=st.sampled_from([0.0, 0.05, 0.3, 0.8]),
    plan_every=st.integers(1, 6),
    window=st.integers(1, 6),
    min_gap=st.sampled_from([DEFAULT_MIN_GAP, 0.3, 0.8, 1.0]),
    turning=st.booleans(),
)
def test_no_conflict_whatever_the_delays_and_every_window_completes(
    fleet, seed, slow, p_delay, plan_every, window, min_gap, turning
):
    """Vertex and swap conflicts are checked every tick by the grid twin (in ``run``);
    once delays end, the last window completes within its last release plus the ticks
    of all its actions (the no-deadlock bound of the module). Four-direction and
    turning robots."""
    if fleet is None:
        return
    grid, starts, goals = fleet
    rng = np.random.default_rng(seed)
    mixed = rng.integers(1, 4, len(starts))
    needed = {"one tick": 1, "same ticks": 3, "mixed ticks": mixed}[slow]
    headings = rng.integers(0, 4, len(starts)) if turning else None
    stop_at = 30
    executor, last_plan, _ = run(
        grid, starts, goals, needed, seed=seed, p_delay=p_delay, ticks=stop_at + 1,
        plan_every=plan_every, window=window, stop_at=stop_at, min_gap=min_gap,
        headings=headings,
    )  # fmt: skip
    ticks_needed = executor.ticks_needed
    last_release = last_plan + ticks_needed.max() * (window + 1)
    bound = max(executor.tick, last_release) + int(ticks_needed.sum()) * (window + 1)
    world = AsyncGrid(grid, executor.left, ticks_needed, executor.headings)
    world.entered[:], world.done[:] = executor.entered, executor.done
    if turning:
        world.facing[:] = executor.facing
    while not executor.window_done() or executor.done.any():
        assert executor.tick <= bound, "the window did not complete: deadlock"
        before = executor.held()
        report = executor.step()
        check_tick(world, executor, before, report, None, executor.tick)
    assert (executor.drift() == 0).all()


@given(
    fleet=fleets,
    seed=st.integers(0, 2**16),
    plan_every=st.integers(1, 5),
    window=st.integers(1, 6),
    corner_follows=st.booleans(),
    turning=st.booleans(),
)
def test_without_delays_one_tick_moves_are_the_lock_step_plan(
    fleet, seed, plan_every, window, corner_follows, turning
):
    """Rotations and follows (corner follows too) included: at tick ``t0 + s`` every
    robot stands (and faces) where the plan given at ``t0`` puts it at step ``s``."""
    if fleet is None:
        return
    grid, starts, goals = fleet
    headings = np.random.default_rng(seed).integers(0, 4, len(starts)) if turning else None
    moves = "rotate" if turning else "grid"
    planner = PIBT(grid, corner_follows=corner_follows, moves=moves, seed=seed)
    executor = Executor(grid, starts, 1, headings=headings)
    for tick in range(24):
        if tick % plan_every == 0:
            path = pibt_window(planner, executor.plan_cells(), goals, window,
                               headings=executor.plan_headings())  # fmt: skip
            executor.add_plan(path)
            given_at = tick
        report = executor.step()
        step = min(tick + 1 - given_at, window)
        expected = path[:, step, 0] * grid.cols + path[:, step, 1]
        assert (executor.left == expected).all()
        assert (executor.entered == expected).all()
        if turning:
            assert (executor.headings == path[:, step, 2]).all()
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


def test_a_line_of_robots_moves_as_one_and_stops_behind_a_delay():
    """Moves of 3 ticks: a line of four goes together, a cell apart; when the head is
    delayed in mid-move, the robots behind it stop too (they would close in)."""
    executor = corridor(4, 3)
    executor.add_plan(straight_path(executor, 2))
    assert executor.step().advanced.all()
    report = executor.step(np.array([True, False, False, False]))
    assert report.own_delay.tolist() == [True, False, False, False]
    assert report.knock_on.tolist() == [False, True, True, True]
    for _ in range(5):
        assert executor.step().advanced.all()
    assert executor.window_done()
    assert not executor.done.any()
    assert executor.plan_cells()[:, 1].tolist() == [5, 4, 3, 2]


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
    """Robots in mid-move plan from the cells they enter; one following another in
    mid-move still keeps its gap under the new plan, and stops when the other is delayed."""
    executor = corridor(2, 3)
    executor.add_plan(straight_path(executor, 3))
    executor.step()
    assert executor.done.tolist() == [1, 1]
    assert executor.plan_cells().tolist() == [[0, 2], [0, 1]]
    executor.add_plan(straight_path(executor, 2))
    report = executor.step(np.array([True, False]))
    assert report.go.tolist() == [True, False]
    assert report.knock_on.tolist() == [False, True]
    goes = [executor.step().go.tolist() for _ in range(3)]
    assert goes == [[True, True]] * 3
    assert executor.held().tolist() == [[2, 3], [1, 2]]
    assert executor.drift().tolist() == [1, 1]


@pytest.mark.parametrize("ticks", [1, 3])
def test_a_rotation_goes_as_one(ticks):
    """Four robots round a 2 x 2 square: a delayed one holds them all, then they go
    together, tick by tick, and all end their moves on the same tick."""
    grid = WarehouseGrid.from_layout(["S.", ".."])
    cells = np.array([(0, 0), (0, 1), (1, 1), (1, 0)])
    executor = Executor(grid, cells, ticks)
    turned = cells[[1, 2, 3, 0]]
    executor.add_plan(np.stack([cells, turned], axis=1))
    assert not executor.step(np.array([False, False, True, False])).go.any()
    for tick in range(ticks):
        if tick == 1:  # in mid-move too, one delayed robot holds the rotation
            assert not executor.step(np.array([True, False, False, False])).advanced.any()
        assert executor.step().advanced.all()
        assert len(set(executor.done.tolist())) == 1
    assert (executor.plan_cells() == turned).all()
    assert executor.window_done()
    assert not executor.done.any()


def test_turning_robots_take_ticks_to_turn_and_their_plans_are_checked():
    """A quarter turn takes the ticks of a move, in place; a plan must start from the
    robots' headings and move each forward along its heading or turn it a quarter."""
    grid = WarehouseGrid.from_layout(["S..", "..."])
    executor = Executor(grid, np.array([(0, 0)]), 2, headings=np.array([0]))
    executor.add_plan(np.array([[(0, 0, 0), (0, 0, 1), (1, 0, 1)]]))  # turn south, go down
    facing = []
    for _ in range(4):
        report = executor.step()
        facing.append((int(executor.headings[0]), int(report.facing[0]), int(executor.left[0])))
    assert facing == [(0, 1, 0), (1, 1, 0), (1, 1, 0), (1, 1, 3)]
    cases = {
        "must start from plan_headings": [(1, 0, 2), (1, 0, 2)],
        "not a forward move": [(1, 0, 1), (1, 1, 1)],  # sideways
        "quarter turn": [(1, 0, 1), (1, 0, 3)],  # a half turn
        r"heading 4": [(1, 0, 1), (1, 0, 4)],
    }
    for message, steps in cases.items():
        with pytest.raises(ValueError, match=message):
            executor.add_plan(np.array([steps]))
    with pytest.raises(ValueError, match=r"\(row, col, heading\)"):
        executor.add_plan(np.array([[(1, 0), (1, 0)]]))
    with pytest.raises(ValueError, match="headings must be"):
        Executor(grid, np.array([(0, 0)]), 1, headings=np.array([5]))
