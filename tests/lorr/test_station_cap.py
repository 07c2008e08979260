"""The station cap: a pairing is offered, at each first stop, only as many open tasks as
the stop has room for, so no stop ever has more than the cap on their way to it; the
fleet's errand list keeps it through every hand-out, rematching included."""

from contextlib import contextmanager
from fractions import Fraction
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.lorr import station_cap
from warehouse_phys.lorr.errands import ScheduledTasks
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling_assignment import AssignmentScheduler, scheduler_for
from warehouse_phys.lorr.station_cap import (
    STATION_CAP,
    offered_within_cap,
    station_loads,
    stop_caps,
)
from warehouse_phys.world.grid import WarehouseGrid

GRID = WarehouseGrid(6, 7)


@contextmanager
def recorded_stop_caps():
    """Each stop's cap as :func:`stop_caps` last gave it, ``{stop: cap}``, filled as the
    code under test calls it."""
    caps: dict[int, int] = {}

    def recording(stops, cap):
        result = stop_caps(stops, cap)
        caps.clear()
        caps.update(zip(np.asarray(stops).tolist(), result.tolist(), strict=True))
        return result

    with mock.patch.object(station_cap, "stop_caps", recording):
        yield caps


def test_each_stop_is_offered_its_first_tasks_up_to_its_room():
    stops = np.array([5, 5, 5, 7, 5, 7])
    # stop 5 has one robot on its way (room 1 of 2), stop 7 none (room 2); 9 is no task's
    assert offered_within_cap(stops, np.array([5, 9]), 2).tolist() == [
        True, False, False, True, False, True]  # fmt: skip
    assert not offered_within_cap(stops, np.array([5, 5, 5]), 2)[:3].any()  # over the cap
    assert station_loads(np.array([5, 7, 9, 1]), np.array([5, 9, 9])).tolist() == [1, 0, 2, 0]
    assert station_loads(np.array([5]), np.zeros(0, np.int64)).tolist() == [0]
    assert offered_within_cap(np.zeros(0, np.int64), np.array([3]), 1).tolist() == []
    # a task held by a robot paired again stays offered, and takes no room
    held = np.array([False, False, True, False, False, False])
    assert offered_within_cap(stops, np.array([5, 5]), 2, held=held).tolist() == [
        False, False, True, True, False, True]  # fmt: skip


def test_a_stop_with_more_open_tasks_than_the_mean_stop_has_a_larger_cap():
    # six tasks at stop 1, two at 2, one at 3: the mean stop has three
    stops = np.array([1, 2, 1, 1, 3, 1, 2, 1, 1])
    assert stop_caps(stops, 2).tolist() == [4, 2, 4, 4, 2, 4, 2, 4, 4]
    assert stop_caps(stops, 3).tolist() == [6, 3, 6, 6, 3, 6, 3, 6, 6]
    assert stop_caps(np.array([7, 7]), 5).tolist() == [5, 5]  # the mean stop: the cap
    assert stop_caps(np.zeros(0, np.int64), 2).tolist() == []
    # stop 1 has room for four less the one robot on its way, so three of its tasks
    goals = np.array([1])
    offered = offered_within_cap(stops, goals, 2, backlog=True)
    assert offered.tolist() == [True, True, True, True, True, False, True, False, False]
    assert offered_within_cap(stops, goals, 2).sum() == 4  # a fixed cap: 1 at stop 1
    with pytest.raises(ValueError, match="cap"):
        stop_caps(stops, 0)


@settings(max_examples=200, deadline=None)
@given(stops=st.lists(st.integers(0, 9), max_size=60), cap=st.integers(1, 20))
def test_stop_caps_are_the_cap_times_the_backlog_over_the_mean_rounded_up(stops, cap):
    caps = stop_caps(np.array(stops, np.int64), cap)
    assert caps.dtype == np.int64
    assert caps.shape == (len(stops),)
    if stops:
        mean = Fraction(len(stops), len(set(stops)))
        for stop, got in zip(stops, caps.tolist(), strict=True):
            ratio = cap * stops.count(stop) / mean
            assert got == max(cap, -(-ratio.numerator // ratio.denominator))
            assert got >= cap


@pytest.mark.parametrize("cap", [0, -1, True, 1.5, None])
def test_a_cap_below_one_or_not_an_int_is_refused(cap):
    with pytest.raises(ValueError, match="cap"):
        offered_within_cap(np.array([1]), np.array([1]), cap)
    if cap is not None:
        with pytest.raises(ValueError, match="cap"):
            AssignmentScheduler(GRID, station_cap=cap)
    with pytest.raises(ValueError, match="held must be one bool a task"):
        offered_within_cap(np.array([1, 2]), np.array([1]), 2, held=np.array([True]))


@settings(max_examples=200, deadline=None)
@given(
    tasks=st.lists(st.tuples(st.integers(0, 5), st.booleans()), max_size=30),
    goals=st.lists(st.integers(0, 7), max_size=30),
    cap=st.integers(1, 6),
    backlog=st.booleans(),
)
def test_held_tasks_and_the_first_others_at_each_stop_up_to_its_room_are_offered(
    tasks, goals, cap, backlog
):
    stops = np.array([stop for stop, _ in tasks], np.int64)
    held = np.array([hold for _, hold in tasks], bool)
    goals = np.array(goals, np.int64)
    offered = offered_within_cap(stops, goals, cap, held=held, backlog=backlog)
    assert offered[held].all()
    caps = stop_caps(stops, cap) if backlog else np.full(len(stops), cap)
    for stop in np.unique(stops):
        at = np.flatnonzero((stops == stop) & ~held)
        its_cap = int(caps[stops == stop][0])
        room = max(its_cap - int((goals == stop).sum()), 0)
        assert offered[at].tolist() == [i < room for i in range(len(at))]
    assert (offered_within_cap(stops, goals, cap) == offered_within_cap(
        stops, goals, cap, held=np.zeros(len(stops), bool))).all()  # fmt: skip


def test_scheduler_names():
    capped = scheduler_for("rematch-capped", GRID)
    assert (capped.rematch, capped.station_cap, capped.__name__) == (
        True, STATION_CAP, "rematch-capped")  # fmt: skip
    assert scheduler_for("rematch-capped=0.25", GRID).length_weight == 0.25
    assert scheduler_for("rematch", GRID).station_cap is None
    assert AssignmentScheduler(GRID, station_cap=3).__name__ == "assignment-capped"
    backlog = scheduler_for("rematch-backlog=0.25", GRID)
    assert (backlog.rematch, backlog.station_cap, backlog.cap_follows_backlog,
            backlog.length_weight, backlog.__name__) == (
        True, STATION_CAP, True, 0.25, "rematch-backlog")  # fmt: skip
    assert not capped.cap_follows_backlog
    assert AssignmentScheduler(GRID, station_cap=3, cap_follows_backlog=True).__name__ == (
        "assignment-backlog")  # fmt: skip
    with pytest.raises(ValueError, match="cap_follows_backlog needs a station_cap"):
        AssignmentScheduler(GRID, cap_follows_backlog=True)


def instance(tasks, starts, reveal=1.0):
    offsets = np.cumsum([0] + [len(t) for t in tasks])
    return LorrInstance(name="t", grid=GRID, starts=starts, task_offsets=offsets,
                        task_stops=[s for t in tasks for s in t], num_tasks_reveal=reveal,
                        assignment="scheduler", version="2024 LoRR")  # fmt: skip


def test_a_full_station_sends_the_next_robot_elsewhere():
    # Three robots beside station 0 (cells 1, 7, 8); tasks 0-2 begin at 0 and task 3 at
    # cell 41, far away. Uncapped, all three go to 0; with a cap of 2 the third goes to 41.
    # With the cap following the backlog: six open tasks (the file's four, then its first
    # two again), five at station 0 and one at 41, the mean stop three: 0's cap is 4, and
    # all three go there.
    tasks = [[0, 20], [0, 21], [0, 22], [41, 20]]
    for cap, backlog, going_to_0 in ((None, False, 3), (2, False, 2), (2, True, 3)):
        scheduler = AssignmentScheduler(GRID, station_cap=cap, cap_follows_backlog=backlog)
        errands = ScheduledTasks(instance(tasks, [1, 7, 8], reveal=2.0), scheduler=scheduler)
        errands.reset(np.array([1, 7, 8]))
        assert (errands.goals == 0).sum() == going_to_0
        assert (errands.tasks >= 0).all()


def test_a_robot_paired_again_at_a_full_station_may_keep_its_own_task():
    # One robot at cell 21, three moves from station 0 (so paired again each step); the
    # station is full with it alone (cap 1), but its own task stays offered: it keeps it
    # rather than being sent to cell 41, eight moves away.
    tasks = [[0, 20], [41, 20], [0, 22]]
    errands = ScheduledTasks(
        instance(tasks, [21], reveal=3.0),
        scheduler=AssignmentScheduler(GRID, rematch=True, station_cap=1),
    )
    errands.reset(np.array([21]))
    mine = errands.tasks.tolist()
    assert errands.goals.tolist() == [0]
    for _ in range(3):
        errands.step(np.zeros(0, np.int64), np.array([21]))
        assert errands.tasks.tolist() == mine


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 10), st.integers(1, 3), st.booleans())
def test_no_stop_ever_has_more_robots_on_their_way_than_the_cap(seed, robots, cap, rematch):
    rng = np.random.default_rng(seed)
    stations = rng.choice(42, size=3, replace=False)  # every task begins at one of three
    tasks = [[int(rng.choice(stations)), int(rng.integers(0, 42))] for _ in range(60)]
    errands = ScheduledTasks(instance(tasks, list(range(robots)), reveal=1.5),
                             scheduler=AssignmentScheduler(GRID, rematch=rematch,
                                                           station_cap=cap))  # fmt: skip
    here = rng.integers(0, 42, size=robots)
    errands.reset(here)
    for _ in range(40):
        going = (errands.tasks >= 0) & (errands.progress == 0)
        assert np.bincount(errands.goals[going], minlength=42).max(initial=0) <= cap
        busy = errands.tasks[errands.tasks >= 0]
        assert len(np.unique(busy)) == len(busy)
        assert (errands.open_robots >= 0).sum() == len(busy)
        # without rematching, a robot goes without a task only while every stop with
        # open tasks is full (a robot paired again holds its stop's room while paired)
        waiting = errands.open_ids[errands.open_robots < 0]
        if not rematch and (errands.tasks < 0).any() and waiting.size:
            firsts = np.asarray(errands.instance.task_stops)[
                np.asarray(errands.instance.task_offsets)[waiting % len(tasks)]
            ]
            assert (station_loads(firsts, errands.goals[going]) >= cap).all()
        held, opened = errands.tasks.copy(), (errands.progress > 0) & (errands.tasks >= 0)
        arrived = np.flatnonzero((rng.random(robots) < 0.4) & (errands.tasks >= 0))
        here = rng.integers(0, 42, size=robots)
        finished = errands.step(arrived, here)
        still = opened & ~np.isin(np.arange(robots), finished)
        assert (errands.tasks[still] == held[still]).all()  # an opened task stays


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.integers(1, 3), st.booleans())
def test_with_the_backlog_no_hand_out_fills_a_stop_past_its_cap(seed, robots, cap, rematch):
    # Each step, a stop's robots on their way after the hand-out are at most its cap as
    # stop_caps gave it for that hand-out, unless there were more before (robots are
    # never taken off their way to make room). Stations with few and many tasks alike.
    rng = np.random.default_rng(seed)
    stations = rng.choice(42, size=3, replace=False)
    weights = rng.dirichlet(np.ones(3))
    tasks = [[int(rng.choice(stations, p=weights)), int(rng.integers(0, 42))] for _ in range(60)]
    scheduler = AssignmentScheduler(GRID, rematch=rematch, station_cap=cap,
                                    cap_follows_backlog=True)  # fmt: skip
    errands = ScheduledTasks(instance(tasks, list(range(robots)), reveal=1.5),
                             scheduler=scheduler)  # fmt: skip
    here = rng.integers(0, 42, size=robots)

    def loads():
        going = (errands.tasks >= 0) & (errands.progress == 0)
        return np.bincount(errands.goals[going], minlength=42)

    with recorded_stop_caps() as caps:
        errands.reset(here)
        for _ in range(40):
            before = loads()
            arrived = np.flatnonzero((rng.random(robots) < 0.4) & (errands.tasks >= 0))
            here = rng.integers(0, 42, size=robots)
            caps.clear()
            errands.step(arrived, here)
            after = loads()
            for stop in np.flatnonzero(after > before):
                assert after[stop] <= caps.get(int(stop), 0)
            busy = errands.tasks[errands.tasks >= 0]
            assert len(np.unique(busy)) == len(busy)
