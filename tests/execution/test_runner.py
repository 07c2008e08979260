"""Plans executed tick by tick: the caller's holds are as safe as delays, the measures
count what stood robots still, lock step without ticks or delays, bit-identical runs."""

import numpy as np
import pytest

from warehouse_phys.execution.async_grid import AsyncGrid, gap_conflicts, swap_conflicts
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.runner import Execution
from warehouse_phys.planners.named import PLANNERS, TURNING_ONLY
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import neighbour_table

FLOOR = WarehouseGrid.from_layout(["S.......", ".##.##..", "........", ".##.##..", "........"])


def fleet(n, seed):
    rng = np.random.default_rng(seed)
    room = np.argwhere(FLOOR.reachable_mask)
    picks = rng.choice(len(room), 2 * n, replace=False)
    return room[picks[:n]], room[picks[n:]]


def delays(p, seed=3):
    return DelayConfig(seed=seed, min_delay=1, max_delay=6, event_model="bernoulli",
                       p_delay=p, duration_model="uniform")  # fmt: skip


@pytest.mark.parametrize("seed", range(4))
def test_holds_and_delays_never_bring_two_robots_too_close(seed):
    starts, goals = fleet(14, seed)
    run = Execution(FLOOR, starts, ticks_per_move=3, speeds=[1, 1.5] * 7,
                    delays=delays(0.05), seed=seed)  # fmt: skip
    world = AsyncGrid(FLOOR, run.executor.left, run.executor.ticks_needed)
    rng = np.random.default_rng(seed)
    for _ in range(150):
        held, centres = world.held(), world.centres()
        outcome = run.tick(goals, rng.random(14) < 0.2)
        world.step(outcome.report.go, outcome.report.heading, outcome.delayed | outcome.held)
        assert (world.held() == run.executor.held()).all()
        after = world.held()
        assert gap_conflicts((held, after), (centres, world.centres()), run.executor.min_gap) == 0
        assert swap_conflicts(held, after) == 0
    m = run.measures
    assert (m.ticks, m.robot_ticks, m.plans) == (150, 150 * 14, 50)
    assert min(m.own_delay, m.held, m.knock_on, m.drift) > 0


def test_the_measures_tell_own_delay_from_holds_and_knock_on():
    grid = WarehouseGrid.from_layout(["S" + "." * 9])
    run = Execution(grid, [(0, 1), (0, 0)], ticks_per_move=1)
    goals = [(0, 9), (0, 8)]
    run.tick(goals, np.array([True, False]))  # robot 0 held, robot 1 stuck behind it
    assert (run.measures.held, run.measures.knock_on, run.measures.own_delay) == (1, 1, 0)
    assert run.tick(goals).report.advanced.all()
    assert run.measures.shares()["held_share"] == 0.25


def test_one_tick_moves_without_delays_are_lock_step_pibt():
    starts, goals = fleet(12, 7)
    run = Execution(FLOOR, starts, seed=7)
    planner = PIBT(FLOOR, corner_follows=True, seed=7)
    table = neighbour_table(FLOOR)
    here = starts[:, 0] * FLOOR.cols + starts[:, 1]
    for _ in range(30):
        here = table[here, planner.plan(np.stack(np.divmod(here, FLOOR.cols), axis=1), goals)]
        run.tick(goals)
        assert (run.executor.left == here).all()


def test_runs_are_bit_identical_for_the_same_seeds():
    starts, goals = fleet(10, 1)

    def trace():
        run = Execution(FLOOR, starts, ticks_per_move=4, delays=delays(0.1), seed=1)
        return np.stack([run.tick(goals).report.advanced for _ in range(60)])

    assert (trace() == trace()).all()


def test_bad_arguments_are_refused_in_one_line():
    starts, _ = fleet(2, 0)
    for kwargs, error, message in [
        ({"ticks_per_move": 0}, ValueError, "ticks_per_move"),
        ({"window": 0}, ValueError, "window"),
        ({"plan_every": 2.5}, TypeError, "plan_every"),
        ({"delays": {"pDelay": 0.1}}, TypeError, "delays must be a DelayConfig"),
        ({"speeds": [1.0]}, ValueError, "speed"),
    ]:
        with pytest.raises(error, match=message):
            Execution(FLOOR, starts, **kwargs)
    run = Execution(FLOOR, starts)
    with pytest.raises(ValueError, match="hold must be"):
        run.tick(starts, np.array([1, 0]))


GUIDED_CASES = [(name, turning) for name in PLANNERS if name != "pibt"
                for turning in ([True] if name in TURNING_ONLY else [False, True])]  # fmt: skip


@pytest.mark.parametrize(("name", "turning"), GUIDED_CASES)
def test_every_guided_planner_runs_on_ticks_as_safely_and_bit_identically(name, turning):
    """Every planner by name but plain PIBT (whose requests the tests above take) is a
    guided one: its windows have no requests, so robots a delay holds are held after its
    plan (:func:`held_back`); every tick still keeps the gap."""
    starts, goals = fleet(12, 5)
    headings = np.zeros(12, dtype=np.int64) if turning else None

    def trace():
        run = Execution(FLOOR, starts, ticks_per_move=3, delays=delays(0.05), seed=2,
                        planner=name, headings=headings)  # fmt: skip
        world = AsyncGrid(FLOOR, run.executor.left, run.executor.ticks_needed, headings)
        cells = []
        for _ in range(120):
            held, centres = world.held(), world.centres()
            outcome = run.tick(goals)
            world.step(outcome.report.go, outcome.report.heading, outcome.delayed,
                       outcome.report.facing)  # fmt: skip
            assert gap_conflicts((held, world.held()), (centres, world.centres()),
                                 run.executor.min_gap) == 0  # fmt: skip
            assert swap_conflicts(held, world.held()) == 0
            cells.append(run.executor.left.copy())
        return np.array(cells), run

    first, run = trace()
    assert type(run.planner).__name__ == "GuidedPIBT"
    assert (first == trace()[0]).all()
    assert (first[-1] != first[0]).any()


def test_a_planner_by_an_unknown_name_is_refused():
    starts, _ = fleet(3, 1)
    with pytest.raises(ValueError, match="unknown planner 'lacam'"):
        Execution(FLOOR, starts, planner="lacam")
