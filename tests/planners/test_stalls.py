import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.pibt.stalls import STALL_FRACTION, STALL_WINDOW, StallWatch
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
    assert watch.stalled  # once stalled, stalled


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
    for window in (0, 1.5, True):
        with pytest.raises(ValueError, match="window must be an integer >= 1"):
            StallWatch(window=window)
    for fraction in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="fraction must be 0 to 1"):
            StallWatch(fraction=fraction)


def dead_end_run(hand_over: bool, steps: int = 80) -> tuple[np.ndarray, bool]:
    """robot_0 drives south to the mouth (1, 1) of the dead end (2, 1), its goal, where
    robot_1 stands facing out with a goal outside; planned over operations. Returns which
    robots arrived and whether the planner handed over."""
    grid = WarehouseGrid.from_layout(["....", "....", "#.##"])
    cols = grid.cols
    cells = np.array([(0, 1), (2, 1)])
    goals = np.array([(2, 1), (0, 3)])
    headings = np.array([1, 3])
    planner = GuidedPIBT(grid, seed=0, moves="rotate", operations=3,
                         hand_over_on_stall=hand_over)  # fmt: skip
    arrived = np.zeros(2, dtype=bool)
    for _ in range(steps):
        actions = planner.plan(cells, goals, ~arrived, headings=headings)
        grants = turning_moves(grid, cells[:, 0] * cols + cells[:, 1], headings, actions,
                               arrived)  # fmt: skip
        assert not grants.refused.any()
        cells, headings = np.column_stack(np.divmod(grants.ends, cols)), grants.headings
        arrived |= (cells == goals).all(axis=1)
    return arrived, planner.stall_watch is not None and planner.stall_watch.stalled


def test_a_planner_over_operations_hands_a_jam_at_a_dead_end_over_to_pibt():
    """Over operations the two robots face each other at the mouth for ever; once the
    watch sees the stall, one-step PIBT's swap operation lets robot_1 out and both arrive."""
    arrived, stalled = dead_end_run(hand_over=False)
    assert not stalled
    assert not arrived.any()
    arrived, stalled = dead_end_run(hand_over=True)
    assert stalled
    assert arrived.all()
