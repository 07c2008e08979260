import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.pibt.stalls import (
    CALM_PLANS,
    CALM_SHARE,
    STALL_FRACTION,
    STALL_WINDOW,
    STILL_PLANS,
    STILL_SHARE,
    StallWatch,
)
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import TurnAction, turning_moves

FORWARD, WAIT = int(TurnAction.FORWARD), int(TurnAction.WAIT)


def plan_with(share: float, robots: int = 10) -> np.ndarray:
    """A plan sending ``share`` of ``robots`` forward, the rest waiting."""
    forward = round(share * robots)
    return np.array([FORWARD] * forward + [WAIT] * (robots - forward))


def test_a_fleet_that_drives_half_as_much_as_it_did_has_stalled():
    watch = StallWatch(window=4, fraction=0.5)
    moving = np.ones(10, dtype=bool)
    assert not any(watch.observe(plan_with(0.6), moving) for _ in range(10))
    assert watch.best == pytest.approx(0.6)
    said = [watch.observe(plan_with(0.2), moving) for _ in range(4)]
    # Averages over the last 4 plans: 0.5, 0.4, 0.3 (not yet below 0.3), then 0.2.
    assert said == [False, False, False, True]
    assert watch.stalled
    assert not watch.observe(plan_with(0.6), moving)  # a plan that is not a stall
    assert watch.stalled  # stalled until the watch sees the jam cleared


def test_only_the_moving_robots_count_and_a_plan_without_them_says_nothing():
    watch = StallWatch(window=1, fraction=0.5)
    actions = np.array([FORWARD, FORWARD, WAIT, WAIT])
    assert not watch.observe(actions, np.array([True, True, False, False]))
    assert watch.best == 1.0
    assert not watch.observe(actions, np.zeros(4, dtype=bool))
    assert watch.observe(actions, np.array([False, True, True, True]))  # 1/3 < 0.5


@given(st.lists(st.floats(0, 1), min_size=1, max_size=60), st.integers(1, 8))
def test_a_fleet_whose_forward_share_never_falls_is_never_stalled(shares, window):
    watch = StallWatch(window=window)
    moving = np.ones(20, dtype=bool)
    for share in sorted(shares):
        assert not watch.observe(plan_with(share, 20), moving)


def test_the_watch_refuses_a_bad_window_or_fraction():
    assert (STALL_WINDOW, STALL_FRACTION) == (20, 0.5)
    assert (STILL_PLANS, STILL_SHARE, CALM_PLANS, CALM_SHARE) == (50, 0.05, 50, 0.001)
    for window in (0, 1.5, True):
        with pytest.raises(ValueError, match="window must be an integer >= 1"):
            StallWatch(window=window)
        with pytest.raises(ValueError, match="still_plans must be an integer >= 1"):
            StallWatch(still_plans=window)
        with pytest.raises(ValueError, match="calm_plans must be an integer >= 1"):
            StallWatch(calm_plans=window)
    for fraction in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="fraction must be 0 to 1"):
            StallWatch(fraction=fraction)
        with pytest.raises(ValueError, match="still_share must be 0 to 1"):
            StallWatch(still_share=fraction)
        with pytest.raises(ValueError, match="calm_share must be 0 to 1"):
            StallWatch(calm_share=fraction)


def test_robots_still_away_from_their_goals_are_a_stall_the_forward_share_misses():
    """98 of 100 robots drive on (a forward share that never falls), 3 stand in a jam:
    once they have stood 5 plans, 3 > 2 % of the fleet. Robots on their goals and parked
    robots do not count, and a robot that moves starts again."""
    watch = StallWatch(window=2, still_plans=5, still_share=0.02)
    n, goal = 100, np.full(100, -1)
    moving = np.ones(n, dtype=bool)
    plan = plan_with(0.97, n)
    here = np.arange(n) * 10
    said = []
    for _ in range(8):
        here = here + np.r_[np.zeros(3, np.int64), np.ones(n - 3, np.int64)]  # 3 stand
        said.append(watch.observe(plan, moving, here, goal))
    assert said == [False] * 5 + [True] * 3  # 5 plans stood after the first one seen
    assert watch.stalled
    assert watch.best == pytest.approx(0.97)
    assert list(watch.still[:4]) == [7, 7, 7, 0]

    for stands_on_goal, parked in ((True, False), (False, True)):
        watch = StallWatch(window=2, still_plans=5, still_share=0.02)
        here = np.arange(n) * 10
        goal = here.copy() if stands_on_goal else np.full(n, -1)
        moving = np.ones(n, dtype=bool)
        moving[:3] = not parked
        for _ in range(8):
            here = here + np.r_[np.zeros(3, np.int64), np.ones(n - 3, np.int64)]
            goal[:3] = here[:3] if stands_on_goal else -1
            assert not watch.observe(plan, moving, here, goal)
        assert not watch.stalled

    watch = StallWatch(window=2, still_plans=5, still_share=0.0)
    one, here, goal = np.ones(1, bool), np.zeros(1, np.int64), np.full(1, 9)
    said = [watch.observe(plan_with(1.0, 1), one, here, goal) for _ in range(5)]
    here[0] = 1  # it moves: its count starts again
    said += [watch.observe(plan_with(1.0, 1), one, here, goal) for _ in range(6)]
    assert said == [False] * 10 + [True]
    assert not watch.observe(plan_with(1.0, 2), np.ones(2, bool), np.zeros(2), np.ones(2))
    assert list(watch.still) == [0, 0]  # a fleet of another size: nothing seen yet


@given(st.lists(st.integers(0, 3), min_size=2, max_size=12), st.integers(1, 6),
       st.integers(0, 40))  # fmt: skip
def test_robots_that_keep_moving_are_never_still(moves, still_plans, steps):
    """Every robot leaves its cell each plan (whatever the forward share): never a stall
    of still robots, and every count stays 0."""
    watch = StallWatch(window=1, fraction=0.0, still_plans=still_plans, still_share=0.0)
    here = np.arange(len(moves)) * 100
    for _ in range(steps):
        here = here + 1 + np.asarray(moves)
        assert not watch.observe(np.asarray(moves), np.ones(len(moves), bool), here,
                                 np.full(len(moves), -1))  # fmt: skip
    assert not watch.stalled


def dead_end_run(
    hand_over: bool,
    steps: int = 80,
    watch: StallWatch | None = None,
    repair: WindowRepair | None = None,
) -> tuple[np.ndarray, bool]:
    """robot_0 drives south to the mouth (1, 1) of the dead end (2, 1), its goal, where
    robot_1 stands facing out with a goal outside; planned over operations (the planner's
    stall watch replaced by ``watch``, if given; repaired by ``repair``, if given).
    Returns which robots arrived and whether the planner handed over at any plan."""
    grid = WarehouseGrid.from_layout(["....", "....", "#.##"])
    cols = grid.cols
    cells = np.array([(0, 1), (2, 1)])
    goals = np.array([(2, 1), (0, 3)])
    headings = np.array([1, 3])
    planner = GuidedPIBT(grid, seed=0, moves="rotate", operations=3,
                         hand_over_on_stall=hand_over, repair=repair, repair_depth=2)  # fmt: skip
    if watch is not None:
        planner.stall_watch = watch
    arrived, handed = np.zeros(2, dtype=bool), False
    for _ in range(steps):
        actions = planner.plan(cells, goals, ~arrived, headings=headings)
        handed |= planner.operations is None
        grants = turning_moves(grid, cells[:, 0] * cols + cells[:, 1], headings, actions,
                               arrived)  # fmt: skip
        assert not grants.refused.any()
        cells, headings = np.column_stack(np.divmod(grants.ends, cols)), grants.headings
        arrived |= (cells == goals).all(axis=1)
    return arrived, handed


def test_a_planner_over_operations_hands_a_jam_at_a_dead_end_over_to_pibt():
    """Over operations the two robots face each other at the mouth for ever; once the
    watch sees the stall, one-step PIBT's swap operation lets robot_1 out and both arrive."""
    arrived, stalled = dead_end_run(hand_over=False)
    assert not stalled
    assert not arrived.any()
    arrived, stalled = dead_end_run(hand_over=True)
    assert stalled
    assert arrived.all()


def test_robots_still_in_a_jam_hand_the_planner_over_too():
    """The forward share's window longer than the run: only the still robots can tell."""
    watch = StallWatch(window=1000, still_plans=10, still_share=0.0)
    arrived, stalled = dead_end_run(hand_over=True, watch=watch)
    assert stalled
    assert watch.best == 0.0  # never a full window of forward shares
    assert arrived.all()
    watch = StallWatch(window=1000, still_plans=100, still_share=0.0)
    arrived, stalled = dead_end_run(hand_over=True, watch=watch)
    assert not stalled  # not still for long enough in 80 plans
    assert not arrived.any()
    assert watch.still.max() == 79


def test_a_repaired_planner_hands_over_unrepaired_and_back_repaired():
    """Handed over, the planner plans one step a step without its repair (repaired
    one-step plans jammed dense random floors); handed back, it plans over the same
    operations with the same repair. A planner that never had operations has nothing to
    hand over or back."""
    arrived, handed = dead_end_run(hand_over=True, repair=WindowRepair(iterations=0))
    assert handed
    assert arrived.all()
    grid = WarehouseGrid.from_layout(["...."])
    repair = WindowRepair(iterations=50)
    planner = GuidedPIBT(grid, moves="rotate", operations=3, repair=repair)
    operations = planner.operations
    assert planner._window is operations
    planner.hand_over()
    assert planner.operations is None
    assert planner.repair is None
    assert planner._window is None
    planner.hand_back()
    assert planner.operations is operations
    assert planner.repair is repair
    assert planner._window is operations
    planner.hand_back()  # nothing handed over: nothing changes
    assert planner.operations is operations
    one_step = GuidedPIBT(grid, moves="rotate", repair=repair)
    window = one_step._window
    one_step.hand_over()
    assert one_step.operations is None
    assert one_step.repair is repair
    assert one_step._window is window


def test_a_jam_has_cleared_after_calm_plans_with_no_robot_still_and_the_watch_starts_anew():
    """Two robots of ten stand still (2 plans on their cells make them still): the jam
    holds; once they move, ``calm_plans`` (4) plans in a row with none still clear it,
    and the watch is as new. Robots still again restart the count."""
    watch = StallWatch(window=2, still_plans=2, still_share=0.1, calm_plans=4)
    n, goal, moving = 10, np.full(10, -1), np.ones(10, dtype=bool)
    here = np.arange(n) * 10
    stand = np.r_[np.zeros(2, np.int64), np.ones(n - 2, np.int64)]
    for _ in range(6):
        here = here + stand
        watch.observe(plan_with(0.8, n), moving, here, goal)
    assert watch.stalled
    said = []
    for step in [stand] * 3 + [1] * 2 + [stand] + [0] * 2 + [1] * 4:
        here = here + step  # two stand; all move; two stand, then all; all move
        said.append(watch.cleared(here, goal, moving))
    assert said == [False] * 11 + [True]
    assert not watch.stalled
    assert watch.best == 0.0
    assert watch.still is None


@given(st.integers(1, 30), st.integers(1, 12), st.integers(1, 60))
def test_a_fleet_that_keeps_moving_clears_after_exactly_calm_plans(n, calm_plans, plans):
    watch = StallWatch(calm_plans=calm_plans, still_plans=1)
    here, goal, moving = np.arange(n), np.full(n, -1), np.ones(n, dtype=bool)
    said = []
    for _ in range(plans):
        here = here + n
        said.append(watch.cleared(here, goal, moving))
    expected = [(k + 1) % calm_plans == 0 for k in range(plans)]
    assert said == expected


@pytest.mark.parametrize(
    ("n", "standing", "clears"), [(2000, 2, True), (2000, 3, False), (999, 1, False), (10, 0, True)]
)
def test_a_jam_has_cleared_with_a_few_robots_still_in_a_large_fleet_and_none_in_a_small(
    n, standing, clears
):
    """At most ``calm_share`` (0.1 %) of the moving robots may stand still in a jam that
    has cleared: two of 2,000 (a robot or two stuck for good in a fleet of thousands does
    not keep it handed over for the rest of the run), not three; in a fleet under 1,000
    robots none may."""
    watch = StallWatch(still_plans=1, calm_plans=5)
    here, goal, moving = np.arange(n), np.full(n, -1), np.ones(n, dtype=bool)
    step = np.r_[np.zeros(standing, np.int64), np.full(n - standing, n, np.int64)]
    said = []
    for _ in range(6):
        here = here + step
        said.append(watch.cleared(here, goal, moving))
    assert said == [False] * 4 + [clears] + [False]  # cleared at the 5th, or never


def test_once_the_dead_end_clears_the_planner_plans_over_its_operations_again():
    """The dead-end jam handed over and cleared (both robots home, none still): the planner
    hands back the very operations it handed over, its repair over them again, and the
    stall watch watches them afresh."""
    grid = WarehouseGrid.from_layout(["....", "....", "#.##"])
    cols = grid.cols
    cells, goals = np.array([(0, 1), (2, 1)]), np.array([(2, 1), (0, 3)])
    headings = np.array([1, 3])
    planner = GuidedPIBT(grid, seed=0, moves="rotate", operations=3,
                         repair=WindowRepair(iterations=0))  # fmt: skip
    operations = planner.operations
    arrived, modes = np.zeros(2, dtype=bool), []
    for _ in range(160):
        actions = planner.plan(cells, goals, ~arrived, headings=headings)
        modes.append(planner.operations is not None)
        grants = turning_moves(grid, cells[:, 0] * cols + cells[:, 1], headings, actions,
                               arrived)  # fmt: skip
        cells, headings = np.column_stack(np.divmod(grants.ends, cols)), grants.headings
        arrived |= (cells == goals).all(axis=1)
    assert arrived.all()
    over = modes.index(False)
    back = modes.index(True, over)
    assert back - over >= CALM_PLANS  # at least calm_plans plans one step a step
    assert all(modes[back:])
    assert planner.operations is operations
    assert planner._window is operations
    assert not planner.stall_watch.stalled
    planner.drop_operations_and_repair()  # short of time: one step for good, never back
    for _ in range(CALM_PLANS + 5):
        planner.plan(cells, goals, np.zeros(2, dtype=bool), headings=headings)
    assert planner.operations is None
