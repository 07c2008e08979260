"""The entry's planner: goals as the kit will count them, windows of the steps a round
holds, no rotation ever, the same windows for the same seed."""

import numpy as np
import pytest

from tests.lorr.tiny_kit_instance import tiny_instance
from warehouse_phys.execution.plan_checks import NO_ROBOT
from warehouse_phys.execution.windows import rotation_heads
from warehouse_phys.lorr.startkit.executor import window_steps
from warehouse_phys.lorr.startkit.planner import EntryPlanner, goals_after_queue, with_held
from warehouse_phys.world.headings import HEADING_MOVES, turned
from warehouse_phys.world.traffic import neighbour_table


def test_an_errand_passed_on_the_queue_is_done_by_the_time_the_plan_starts():
    queue = np.array([[5, 6, 7, 7], [5, 6, 7, 7], [9, 9, 9, 9], [5, 5, 5, 5]])
    stops = np.array([[6, 2], [7, 6], [-1, -1], [5, 5]])
    # Robot 0 passes 6: its next is 2; robot 1 passes 7 before 6 would count: still 7 then
    # 6 is not after it; robot 2 has no task; robot 3 stands on 5 for two ticks: both done.
    assert goals_after_queue(queue, stops).tolist() == [2, 6, -1, -1]
    assert goals_after_queue(queue, np.zeros((4, 0), int)).tolist() == [-1] * 4


def test_a_held_tasks_errand_follows_the_last_of_the_current_task():
    stops = np.array([[3, 4, -1], [-1, -1, -1], [5, -1, -1]])
    held = np.array([9, 8, -1])
    assert with_held(stops, held).tolist() == [[3, 4, 9, -1], [8, -1, -1, -1], [5, -1, -1, -1]]


def test_a_window_holds_the_moves_of_a_round():
    # Rounds of 10 ticks, moves of 3: 4 first (staged at once), then 3, 3, 4, ...
    steps = [window_steps(None, 10, 3)] + [window_steps(t, 10, 3) for t in range(0, 90, 10)]
    assert steps == [4, 3, 3, 4, 3, 3, 4, 3, 3, 4]
    total = sum(steps)  # every robot on time has moves until the next plan, and no more
    assert total == -(-(80 + 2 * 10) // 3)  # the plan of tick 80 lasts until tick 100
    assert window_steps(0, 10, 20) in (0, 1)


def test_windows_never_rotate_and_repeat_for_a_seed():
    instance = tiny_instance()
    grid = instance.grid
    ahead = neighbour_table(grid)[:, HEADING_MOVES]
    occupant = np.full(grid.rows * grid.cols, NO_ROBOT)
    rng = np.random.default_rng(0)
    goals = rng.choice(np.flatnonzero(grid.reachable_mask.reshape(-1)), 8)

    def windows(seed):
        planner = EntryPlanner(grid, steps=4, seed=seed)
        here, facing, out = instance.starts.copy(), np.zeros(8, np.int64), []
        for _ in range(20):
            actions = planner.plan(here, facing, goals)
            for step in actions.T:
                wanted = np.where(step == 0, ahead[here, facing], here)
                assert len(rotation_heads(here, wanted, occupant)) == 0
                assert np.unique(wanted).size == 8
                here, facing = wanted, turned(facing, step)
            out.append(actions)
        return np.concatenate(out, axis=1)

    first = windows(0)
    assert (first == windows(0)).all()
    assert (first == 0).any()  # robots drive


def test_an_unknown_planner_is_refused():
    with pytest.raises(ValueError, match="unknown planner 'lacam'"):
        EntryPlanner(tiny_instance().grid, steps=2, planner="lacam")


def test_a_robot_stuck_on_one_cell_takes_a_detour_for_a_while():
    from warehouse_phys.lorr.startkit.planner import DETOUR_PLANS, DETOUR_RADIUS, STUCK_PLANS

    instance = tiny_instance()
    grid = instance.grid
    planner = EntryPlanner(grid, steps=1)
    cells, goals = instance.starts.copy(), instance.starts.copy()
    goals[0] = instance.starts[1]  # robot 0 wants robot 1's cell, every plan from the same cells
    for _ in range(STUCK_PLANS - 1):
        planner.plan(cells, np.zeros(8, np.int64), goals)
        assert (planner.detours == -1).all()
    planner.plan(cells, np.zeros(8, np.int64), goals)
    detour = int(planner.detours[0])
    assert detour >= 0
    assert (planner.detours[1:] == -1).all()
    row, col = divmod(detour, grid.cols)
    here_row, here_col = divmod(int(cells[0]), grid.cols)
    assert max(abs(row - here_row), abs(col - here_col)) <= DETOUR_RADIUS
    assert grid.reachable_mask[row, col]
    for _ in range(DETOUR_PLANS - 1):
        planner.plan(cells, np.zeros(8, np.int64), goals)
    assert planner.detours[0] == -1  # back to its errand


def test_a_time_bound_stops_the_guide_searches_and_the_plan_still_holds():
    instance = tiny_instance()
    grid = instance.grid
    ahead = neighbour_table(grid)[:, HEADING_MOVES]
    occupant = np.full(grid.rows * grid.cols, NO_ROBOT)
    goals = instance.starts[::-1].copy()
    facing = np.zeros(8, np.int64)
    free = EntryPlanner(grid, steps=3).plan(instance.starts, facing, goals)
    roomy = EntryPlanner(grid, steps=3).plan(instance.starts, facing, goals, seconds=60.0)
    assert (roomy == free).all()  # time enough: the unbounded plan
    bounded = EntryPlanner(grid, steps=3)
    actions = bounded.plan(instance.starts, facing, goals, seconds=0.0)
    assert bounded.planner.guidance.timed_out > 0  # no time: robots left unguided
    assert bounded.planner.repair.stats.tried == 0  # ... and no plan repaired
    here = instance.starts.copy()
    for step in actions.T:  # ... and every step is still one the robots can make
        wanted = np.where(step == 0, ahead[here, facing], here)
        assert len(rotation_heads(here, wanted, occupant)) == 0
        assert np.unique(wanted).size == 8
        here, facing = wanted, turned(facing, step)


def test_the_collector_is_paused_and_then_as_it_was():
    import gc

    from warehouse_phys.lorr.startkit.planner import collector_paused

    for enabled in (True, False):
        (gc.enable if enabled else gc.disable)()
        try:
            with collector_paused():
                assert not gc.isenabled()
            assert gc.isenabled() == enabled
        finally:
            gc.enable()


def test_the_collector_stays_paused_until_the_last_of_overlapping_calls_ends():
    """The kit's planner thread and its executor calls overlap: the one that ends first
    must not switch the collector back on under the other."""
    import gc
    import threading

    from warehouse_phys.lorr.startkit.planner import collector_paused

    planning, executor_done = threading.Event(), threading.Event()
    seen = []

    def planner() -> None:
        with collector_paused():
            planning.set()
            executor_done.wait(10)
            seen.append(gc.isenabled())  # after the executor's call ended

    gc.enable()
    try:
        with collector_paused():  # an executor call, begun first
            thread = threading.Thread(target=planner)
            thread.start()
            assert planning.wait(10)
        executor_done.set()
        thread.join(10)
        assert seen == [False]
        assert gc.isenabled()
    finally:
        gc.enable()


def test_a_planner_short_of_time_twice_in_a_row_drops_its_operations_and_repair():
    instance = tiny_instance()
    facing, goals = np.zeros(8, np.int64), instance.starts[::-1].copy()
    roomy = EntryPlanner(instance.grid, steps=3)
    for _ in range(3):
        roomy.plan(instance.starts, facing, goals, seconds=60.0)
    assert not roomy.lightened
    assert roomy.planner.operations is not None
    short = EntryPlanner(instance.grid, steps=3)
    short.plan(instance.starts, facing, goals, seconds=0.0)
    assert not short.lightened  # once may be a slow start
    short.plan(instance.starts, facing, goals, seconds=0.0)
    assert short.lightened
    assert short.planner.operations is None
    assert short.planner.repair is None
    actions = short.plan(instance.starts, facing, goals)  # one action a step from now on
    assert actions.shape == (8, 3)
    assert np.isin(actions, [0, 1, 2, 3]).all()


def test_guidance_sets_the_entrys_fields_over_its_own():
    from warehouse_phys.lorr.startkit.planner import ENTRY_GUIDANCE, ENTRY_REPAIR, entry_planner
    from warehouse_phys.world.grid import WarehouseGrid

    grid = WarehouseGrid(3, 4)
    planner = entry_planner("guided-ops-repair", grid, guidance={"reroute": 4, "iterations": 9})
    assert planner.guidance.config.reroute == 4
    assert planner.guidance.config.vertex_weight == ENTRY_GUIDANCE.vertex_weight  # the entry's own
    assert planner.repair.iterations == 9
    assert planner.repair.neighbourhood == ENTRY_REPAIR["neighbourhood"]
    assert entry_planner("guided", grid, guidance={"window": 3}).guidance.config.window == 3
    assert entry_planner("guided", grid).guidance.config == ENTRY_GUIDANCE
    with pytest.raises(TypeError, match="planner 'guided' has no field 'iterations'"):
        entry_planner("guided", grid, guidance={"iterations": 9})
    with pytest.raises(ValueError, match="plain PIBT takes no guidance"):
        entry_planner("pibt", grid, guidance={"window": 3})
    planner = EntryPlanner(grid, steps=2, planner="guided-repair", guidance={"iterations": 5})
    assert planner.planner.repair.iterations == 5


def test_the_entrys_planner_counts_the_cores_when_it_is_made(monkeypatch):
    """The entry's guide-path threads are the cores the process may run on when its
    planner is made (the kit's process may be given fewer after import), unless set."""
    from warehouse_phys.lorr.startkit import planner
    from warehouse_phys.world.grid import WarehouseGrid

    monkeypatch.setattr(planner, "default_workers", lambda: 3)
    grid = WarehouseGrid(3, 4)
    for name in ("guided", "guided-ops-repair"):  # its own; the others: named_planner
        assert planner.entry_planner(name, grid).guidance.config.workers == 3
        made = planner.entry_planner(name, grid, guidance={"workers": 1})
        assert made.guidance.config.workers == 1
