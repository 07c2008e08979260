"""The entry's scheduler: robots keep their opened tasks, free robots take untaken ones,
robots on their way to a task not opened are paired again, and a task held for a robot
about to be free is proposed for it once the kit frees it."""

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.lorr import station_cap
from warehouse_phys.lorr.rematching import KEEP_WITHIN
from warehouse_phys.lorr.scheduling_assignment import scheduler_for
from warehouse_phys.lorr.startkit.scheduler import (
    ENTRY_SCHEDULERS,
    FLEET_SCHEDULERS,
    EntryScheduler,
    OpenTasks,
)
from warehouse_phys.lorr.station_cap import STATION_CAP, stop_caps

COLS = 10


def tasks(ids, stops, robots, lengths=None):
    lengths = [0] * len(ids) if lengths is None else lengths
    return OpenTasks(*(np.array(v, dtype=np.int64) for v in (ids, stops, lengths, robots)))


def test_robots_keep_their_tasks_and_free_ones_take_the_nearest_untaken():
    scheduler = EntryScheduler(COLS, "nearest")
    pool = tasks([4, 5, 6], [0, 55, 99], [1, -1, -1])
    proposal = scheduler.schedule(np.array([-1, 4, -1]), np.array([98, 0, 56]), pool)
    assert proposal.tolist() == [6, 4, 5]


def test_makespan_prefers_the_shorter_task_of_two_equally_near():
    scheduler = EntryScheduler(COLS, "makespan")
    pool = tasks([1, 2], [11, 13], [-1, -1], lengths=[9, 1])
    assert scheduler.schedule(np.array([-1]), np.array([12]), pool).tolist() == [2]


def test_a_task_held_for_a_finishing_robot_is_proposed_once_it_is_free():
    scheduler = EntryScheduler(COLS, "nearest")
    pool = tasks([7, 8], [21, 90], [0, -1])
    first = scheduler.schedule(np.array([7, -1]), np.array([20, 95]), pool,
                               finishing=np.array([True, False]))  # fmt: skip
    assert first.tolist() == [7, 8]  # robot 0 keeps its task for the kit; robot 1 takes 8
    pool = tasks([8, 9, 10], [90, 22, 23], [1, -1, -1])
    second = scheduler.schedule(np.array([7, 8]), np.array([20, 95]), pool,
                                finishing=np.array([True, False]))  # fmt: skip
    assert scheduler.held.tolist() == [9, -1]
    # The kit freed robot 0: it is proposed for the task held for it, no other robot for it.
    pool = tasks([8, 9, 10], [90, 22, 23], [1, -1, -1])
    third = scheduler.schedule(np.array([-1, 8]), np.array([21, 95]), pool)
    assert (second.tolist(), third.tolist(), scheduler.held.tolist()) == ([7, 8], [9, 8], [-1, -1])


def test_an_unknown_scheduler_is_refused():
    known = "nearest, makespan, assignment, assignment-capped, assignment-backlog"
    with pytest.raises(ValueError, match=f"unknown scheduler 'hungarian'; known: {known}"):
        EntryScheduler(COLS, "hungarian")


def test_robots_on_their_way_to_a_task_not_opened_are_paired_again():
    # Robot 0 at cell 0 is on its way to task 4 at cell 99; robot 1, freed at cell 98,
    # and a new task 5 at cell 1: paired again, each takes the task beside it.
    pool = tasks([4, 5], [99, 1], [0, -1])
    current, cells = np.array([4, -1]), np.array([0, 98])
    again = EntryScheduler(COLS, "nearest").schedule(current, cells, pool,
                                                     unopened=np.array([True, False]))  # fmt: skip
    assert again.tolist() == [5, 4]
    # Told nothing, or told its task is opened, or not to pair again: robot 0 keeps it.
    for scheduler, unopened in ((EntryScheduler(COLS, "nearest"), None),
                                (EntryScheduler(COLS, "nearest"), np.array([False, False])),
                                (EntryScheduler(COLS, "nearest", pair_again=False),
                                 np.array([True, False]))):  # fmt: skip
        assert scheduler.schedule(current, cells, pool, unopened=unopened).tolist() == [4, 5]


def test_a_robot_next_to_its_tasks_first_errand_keeps_it():
    near = KEEP_WITHIN  # moves from cell 0 along the first row
    pool = tasks([4, 5], [near, 1], [0, -1])
    proposal = EntryScheduler(COLS, "nearest").schedule(
        np.array([4, -1]), np.array([0, near + 1]), pool, unopened=np.array([True, False])
    )
    assert proposal.tolist() == [4, 5]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["nearest", "makespan"]))
def test_pairing_again_never_breaks_the_kits_checks_nor_leaves_a_robot_without_a_task(seed, name):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(1, 12)), int(rng.integers(1, 20))
    ids = np.sort(rng.choice(1000, k, replace=False))
    holder = np.full(k, -1)
    current = np.full(n, -1)
    for robot, slot in enumerate(rng.choice(k, min(n, k), replace=False)):
        if rng.random() < 0.7:
            current[robot], holder[slot] = ids[slot], robot
    pool = tasks(ids, rng.integers(0, 100, k), holder, rng.integers(0, 30, k))
    unopened = (current >= 0) & (rng.random(n) < 0.6)
    proposal = EntryScheduler(COLS, name).schedule(current, rng.integers(0, 100, n), pool,
                                                   unopened=unopened)  # fmt: skip
    given_out = proposal[proposal >= 0]
    assert len(set(given_out.tolist())) == len(given_out)  # no task twice
    assert np.isin(given_out, ids).all()
    opened = (current >= 0) & ~unopened
    assert (proposal[opened] == current[opened]).all()  # an opened task stays
    assert (proposal >= 0).sum() == min(n, k)  # every robot a task while tasks are left


def test_pairing_again_on_the_floor_takes_the_way_round_the_shelves():
    from warehouse_phys.world.grid import WarehouseGrid

    # A wall between robot 0 and the cell beside it: by the way round, the far side
    # of the wall is not near, and the robot is paired again.
    grid = WarehouseGrid.from_layout(["....", ".##.", ".#..", ".#.."])
    cols = grid.cols
    pool = tasks([4, 5], [2 * cols + 2, 3 * cols], [0, -1])
    scheduler = EntryScheduler(cols, "assignment", grid)
    proposal = scheduler.schedule(np.array([4, -1]), np.array([2 * cols, 3 * cols + 2]), pool,
                                  unopened=np.array([True, False]))  # fmt: skip
    assert proposal.tolist() == [5, 4]


def _open_floor():
    from warehouse_phys.world.grid import WarehouseGrid

    return WarehouseGrid.from_layout(["." * COLS] * COLS)


def test_the_capped_assignment_sends_no_more_than_the_cap_to_one_station():
    grid, station = _open_floor(), 55
    pool = tasks(list(range(12)), [station] * 12, [-1] * 12)
    free = np.full(10, -1)
    capped = EntryScheduler(COLS, "assignment-capped", grid)
    assert capped.scheduler.station_cap == STATION_CAP
    proposal = capped.schedule(free, np.arange(10), pool, unopened=np.zeros(10, bool))
    assert (proposal >= 0).sum() == STATION_CAP
    uncapped = EntryScheduler(COLS, "assignment", grid)
    assert (uncapped.schedule(free, np.arange(10), pool) >= 0).sum() == 10
    # Three robots already on their way there (tasks 0-2 not opened): room for five more.
    current = np.array([0, 1, 2] + [-1] * 7)
    pool = tasks(list(range(12)), [station] * 12, [0, 1, 2] + [-1] * 9)
    unopened = current >= 0
    proposal = capped.schedule(current, np.full(10, station), pool, unopened=unopened)
    assert proposal[:3].tolist() == [0, 1, 2]
    assert (proposal[3:] >= 0).sum() == STATION_CAP - 3
    with pytest.raises(ValueError, match="give unopened"):
        capped.schedule(current, np.full(10, station), pool)


def test_the_backlog_assignment_sends_more_to_a_station_with_more_open_tasks():
    # Twelve tasks at station 55 and four at station 0: the mean station has eight, so
    # 55's cap is 12 and 0's is 8. Twenty free robots: the fixed cap sends 8 to 55 and
    # 4 to 0; following the backlog, 12 to 55.
    grid = _open_floor()
    pool = tasks(list(range(16)), [55] * 12 + [0] * 4, [-1] * 16)
    free, cells = np.full(20, -1), np.full(20, 54)
    taken = {}
    for name in ("assignment-capped", "assignment-backlog"):
        scheduler = EntryScheduler(COLS, name, grid)
        proposal = scheduler.schedule(free, cells, pool, unopened=np.zeros(20, bool))
        taken[name] = np.bincount(np.asarray(pool.next_stop)[proposal[proposal >= 0]])[[55, 0]]
    assert taken["assignment-capped"].tolist() == [STATION_CAP, 4]
    assert taken["assignment-backlog"].tolist() == [12, 4]
    assert EntryScheduler(COLS, "assignment-backlog", grid).scheduler.cap_follows_backlog


def test_a_robot_paired_again_at_a_full_station_keeps_its_task_on_offer():
    grid, station = _open_floor(), 99
    # Robot 0, far from station 99, is on its way to task 0 there with seven others (the
    # cap), and is paired again; robot 8, free beside the station, and task 9 at cell 9
    # beside robot 0. Task 0 stays on offer (robot 0 holds its place), so the pairing
    # swaps them; no other task at the full station is offered.
    ids = list(range(10))
    current = np.array([0, 1, 2, 3, 4, 5, 6, 7, -1])
    pool = tasks(ids, [station] * 9 + [9], [0, 1, 2, 3, 4, 5, 6, 7, -1, -1])
    cells = np.array([0, 98, 98, 98, 98, 98, 98, 98, 89])
    proposal = EntryScheduler(COLS, "assignment-capped", grid).schedule(
        current, cells, pool, unopened=current >= 0
    )
    assert proposal.tolist() == [9, 1, 2, 3, 4, 5, 6, 7, 0]


@pytest.mark.parametrize("name", ["assignment-capped", "assignment-backlog"])
@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_capped_assignment_never_fills_a_station_past_the_cap(name, seed):
    # Few stations, many robots: the cap binds. Robots on their way to a first stop at
    # each station (tasks not opened, tasks held for robots about to be free and proposed
    # to them once free) after each of two rounds: never above the cap unless they were
    # before.
    rng = np.random.default_rng(seed)
    grid = _open_floor()
    n, k = int(rng.integers(1, 40)), int(rng.integers(1, 60))
    stations = rng.choice(COLS * COLS, int(rng.integers(1, 4)), replace=False)
    ids = np.sort(rng.choice(1000, k, replace=False))
    holder, current = np.full(k, -1), np.full(n, -1)
    for robot, slot in enumerate(rng.choice(k, min(n, k), replace=False)):
        if rng.random() < 0.5:
            current[robot], holder[slot] = ids[slot], robot
    stops = rng.choice(stations, k)
    pool = tasks(ids, stops, holder, rng.integers(0, 30, k))
    scheduler = EntryScheduler(COLS, name, grid)
    busy = current >= 0
    opened = busy & (rng.random(n) < 0.3)
    finishing = opened & (rng.random(n) < 0.5)
    unopened = busy & ~opened
    stop_of = dict(zip(ids.tolist(), stops.tolist(), strict=True))

    def loads(going):
        counted = [stop_of[t] for t in going.tolist()]
        return {s: counted.count(s) for s in stations.tolist()}

    before = loads(current[unopened])
    # Each station's cap in a round: fixed, or what the backlog gave it in that round.
    caps = {}

    def recording(stops, cap):
        result = stop_caps(stops, cap)
        caps.update(zip(np.asarray(stops).tolist(), result.tolist(), strict=True))
        return result

    for _ in range(2):  # the second round: the kit took the proposal, the holds stand
        caps.clear()
        caps.update(dict.fromkeys(stations.tolist(), STATION_CAP))
        with mock.patch.object(station_cap, "stop_caps", recording):
            proposal = scheduler.schedule(current, rng.integers(0, COLS * COLS, n), pool,
                                          finishing, unopened)  # fmt: skip
        held = scheduler.held[scheduler.held >= 0]
        after = loads(np.concatenate([proposal[(proposal >= 0) & ~opened], held]))
        for station in stations.tolist():
            assert after[station] <= max(caps[station], before[station])
        # A round's load is a bound on the next round's load before it pairs.
        before = {s: max(before[s], after[s]) for s in before}
        given_out = np.concatenate([proposal[proposal >= 0], held])
        assert len(set(given_out.tolist())) == len(given_out)  # no task twice
        assert (proposal[opened] == current[opened]).all()  # an opened task stays
        # The kit took the proposal and freed some finishing robots, their tasks done.
        freed = finishing & (rng.random(n) < 0.5)
        done = np.isin(ids, current[freed])
        ids, stops, lengths = ids[~done], stops[~done], pool.length[~done]
        current = np.where(freed, -1, proposal)
        opened &= ~freed
        unopened, finishing, before = (current >= 0) & ~opened, finishing & ~freed, after
        holder = np.full(len(ids), -1)
        holder[np.searchsorted(ids, current[current >= 0])] = np.flatnonzero(current >= 0)
        pool = tasks(ids, stops, holder, lengths)


def test_each_entry_scheduler_is_the_fleet_scheduler_simulate_plays():
    grid = _open_floor()
    for entry, fleet in FLEET_SCHEDULERS.items():
        ours, theirs = EntryScheduler(COLS, entry, grid).scheduler, scheduler_for(fleet, grid)
        for setting in ("station_cap", "cap_follows_backlog", "length_weight"):
            assert getattr(ours, setting, None) == getattr(theirs, setting, None), (entry, setting)
        if hasattr(theirs, "rematch"):  # the entry's assignments always pair again
            assert theirs.rematch, entry
    assert set(FLEET_SCHEDULERS) == set(ENTRY_SCHEDULERS)
