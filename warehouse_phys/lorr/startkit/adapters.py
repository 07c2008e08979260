"""The entry's parts as the start kit's three Python components: its ``MAPF`` types turned into
arrays for :mod:`~warehouse_phys.lorr.startkit.planner`,
:mod:`~warehouse_phys.lorr.startkit.scheduler` and
:mod:`~warehouse_phys.lorr.startkit.executor`, and their answers turned back.

The kit (``python/common/py*.cpp``) loads a class named ``pyMAPFPlanner``,
``pyTaskScheduler`` and ``pyExecutor`` from its ``python/user_*/`` files, sets ``env`` (its
``SharedEnvironment``, shared without copying) and calls ``initialize`` once, then
``plan`` (planner, scheduler) every round and ``process_new_plan`` / ``next_command``
(executor). The files that :mod:`~warehouse_phys.lorr.startkit.install` writes subclass
:class:`PlannerAdapter`, :class:`SchedulerAdapter` and :class:`ExecutorAdapter` under
those names. ``MAPF`` is the kit's own module; it is imported only here, inside the calls.

What the kit does not tell its components, they take from the environment: the robots'
side, ``agentSize`` (``WAREHOUSE_PHYS_AGENT_SIZE``, default 1, the kit's default and
every 2026 example's; a larger value than the instance's is safe, only slower), the
planner (``WAREHOUSE_PHYS_PLANNER``, ``guided-ops-repair``) and its fields
(``WAREHOUSE_PHYS_GUIDANCE``, a JSON object such as ``{"reroute": 32}``; ``{}``, the
entry's own: :func:`~warehouse_phys.lorr.startkit.planner.entry_planner`), and the scheduler
(``WAREHOUSE_PHYS_SCHEDULER``, ``assignment``; ``assignment-capped``,
``assignment-backlog``, ``makespan``, ``nearest``), and the share of the kit's time limit
the planner's round aims at (``WAREHOUSE_PHYS_ROUND_SHARE``, :data:`ROUND_SHARE`; ``none``
for no bound: :func:`round_share`). With ``WAREHOUSE_PHYS_TIMINGS`` set to a
file, each call appends a line ``<call> <wall seconds> <CPU seconds of its thread>`` to
it (the kit ends its process without Python's exit handlers, so nothing waits for the
end).

The kit's Python bridge writes the scheduler's whole answer once it returns, over the
robots the kit freed in the meantime (their tasks finished in the ticks that ran while it
computed), which the kit then counts as schedule errors ("task already finished"). So the
executor, at its first command of a round, waits (at most :data:`SCHEDULER_WAIT` of its
time) until the scheduler of the same interpreter has answered: the kit writes the
answer before it lets the executor go on (it holds Python's lock while it copies it).

Time: the kit's rounds are real time (a late plan costs the robots the ticks they wait
for it, an executor call over its 100 ms a tick of waits for every robot). The planner
aims to end its round, the scheduler's time included, within :data:`ROUND_SHARE` of the
kit's ``time_limit`` (``WAREHOUSE_PHYS_ROUND_SHARE``): the guided planner's guide-path
searches stop there, and the robots left step by PIBT's distances (``seconds`` of
:meth:`~warehouse_phys.lorr.startkit.planner.EntryPlanner.plan`; without the kit, as
:mod:`~warehouse_phys.lorr.startkit.system` runs the entry, there is no such bound and a
run is the same for the same seed). The executor takes the plan from this interpreter's
planner rather than reading the kit's ``Plan`` back (:func:`plan_table`), and every call
runs with Python's cycle collector held off
(:func:`~warehouse_phys.lorr.startkit.planner.collector_paused`).

The executor learns what happened to the tick it commanded from the kit's states at its
next call: the robots it told GO that the kit reports delayed did not advance (the kit
draws a tick's delays after the commands), and a robot told GO that neither advanced nor
was delayed was refused by the kit's action model: it is counted in
:attr:`ExecutorAdapter.refused` (the executor promises none) and treated as delayed, so
the executor's state stays the kit's.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from warehouse_phys.lorr.startkit.executor import EntryExecutor, plan_steps, window_steps
from warehouse_phys.lorr.startkit.planner import (
    EntryPlanner,
    collector_paused,
    goals_after_queue,
    with_held,
)
from warehouse_phys.lorr.startkit.scheduler import EntryScheduler, OpenTasks
from warehouse_phys.lorr.startkit.settings import (
    ROUND_SHARE,
    entry_guidance,
    round_share,
    setting,
)
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES
from warehouse_phys.world.traffic import neighbour_table

_GO, _STOP = 0, 1  # MAPF.ExecutionCommand
#: The share of its time limit the executor's first command of a round waits for the
#: scheduler's answer (the module). At 10,000 robots that command ends about 105 ms
#: after it began, 2 ms of it CPU, with this share at 0.8 or 0.6 alike: the scheduler's
#: thread holds Python's lock until then.
SCHEDULER_WAIT = 0.8
#: Set when this interpreter's scheduler has answered the round's call (see the module).
_SCHEDULED = threading.Event()
#: Whether this interpreter runs the entry's scheduler (else no executor waits for it).
_SCHEDULER = threading.Event()
#: This interpreter's scheduler, whose held tasks its planner plans for.
_SCHEDULERS: list[EntryScheduler] = []
#: The queues' walk (:func:`queue_cells`) of this interpreter's executor once it staged
#: the round's plan, until the scheduler takes it: the kit's staged actions then are those
#: queues, so the scheduler need not read ten thousand of them back.
_EXECUTED: list[np.ndarray] = []
#: The plan this interpreter's planner answered last, until the executor takes it.
_PLANNED: list[np.ndarray] = []
#: When this interpreter's scheduler began the round's computation [perf_counter s].
_ROUND_BEGUN = [0.0]


F = TypeVar("F", bound=Callable[..., Any])


def timed(call: str) -> Callable[[F], F]:
    """A component's method whose wall time goes to ``WAREHOUSE_PHYS_TIMINGS``, if set, run
    with Python's cycle collector held off (:func:`collector_paused`: the calls build
    lists of the kit's objects a robot, and no cycles)."""

    def wrap(method: F) -> F:
        def run(*args: Any, **kwargs: Any) -> Any:
            path = os.environ.get("WAREHOUSE_PHYS_TIMINGS")
            if not path:
                with collector_paused():
                    return method(*args, **kwargs)
            begun, cpu = time.perf_counter(), time.thread_time()
            try:
                with collector_paused():
                    return method(*args, **kwargs)
            finally:
                wall, cpu = time.perf_counter() - begun, time.thread_time() - cpu
                with open(path, "a") as out:
                    out.write(f"{call} {wall:.6f} {cpu:.6f}\n")

        return run  # type: ignore[return-value]

    return wrap


def kit_grid(env: Any) -> WarehouseGrid:
    """The floor of the kit's ``env`` (its ``map``: 1 a blocked cell, ``rows`` x ``cols``)."""
    blocked = np.array(list(env.map), dtype=np.int64).reshape(env.rows, env.cols) == 1
    rows = ["".join("#" if b else "." for b in row) for row in blocked.tolist()]
    return WarehouseGrid.from_layout(rows)


def kit_steps(env: Any) -> int:
    """Actions a robot on time holds for the kit's ``env``
    (:func:`~warehouse_phys.lorr.startkit.executor.plan_steps`); a queue keeps one more."""
    return plan_steps(env.min_planner_communication_time, env.action_time, env.max_counter)


def round_ticks(env: Any) -> int:
    """Ticks between two plans for the kit's ``env`` (when the entry keeps to its time)."""
    return -(-int(env.min_planner_communication_time) // int(env.action_time))


def states_of(states: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(N,)`` locations and ``(N,)`` orientations of the kit's states."""
    pairs = [(s.location, s.orientation) for s in states]
    table = np.array(pairs, dtype=np.int64).reshape(n, 2)
    return table[:, 0], table[:, 1]


def queue_cells(env: Any, ahead: np.ndarray) -> np.ndarray:
    """``(N, W + 1)``: where each robot stands now (``system_states``), then after each of
    its ``staged_actions``, padded with its last cell."""
    here, facing = states_of(env.system_states, env.num_of_agents)
    walks = []
    for robot, staged in enumerate(env.staged_actions):
        cell, face = int(here[robot]), int(facing[robot])
        walk = [cell]
        for action in staged:
            code = int(action)
            if code == 0:
                cell = int(ahead[cell, face])
            elif code in (1, 2):
                face = (face + (1 if code == 1 else 3)) % 4
            walk.append(cell)
        walks.append(walk)
    width = max(map(len, walks), default=1)
    return np.array([walk + [walk[-1]] * (width - len(walk)) for walk in walks], dtype=np.int64)


class TaskBook:
    """What the components keep of the kit's task pool between calls: each task's errands,
    read once (they never change), so that a call reads of the pool only the new tasks'
    errands and the scheduled tasks' progress (the others are not opened: the kit keeps an
    opened task with its robot)."""

    def __init__(self, cols: int) -> None:
        self.cols = int(cols)
        self._stops: dict[int, list[int]] = {}
        self._lengths: dict[int, int] = {}

    def update(self, pool: Any) -> list[int]:
        """The pool's task ids in order (the order they were revealed); new ones read."""
        ids = sorted(pool)
        for task_id in ids:
            if task_id not in self._stops:
                stops = list(pool[task_id].locations)
                self._stops[task_id] = stops
                self._lengths[task_id] = _length(stops, self.cols)
        for gone in set(self._stops) - set(ids):
            del self._stops[gone], self._lengths[gone]
        return ids

    def stops_of(self, pool: Any, schedule: np.ndarray) -> np.ndarray:
        """``(N, M)`` the errands still to do of each robot's task in ``schedule`` (task
        ids, -1 none), padded with -1."""
        self.update(pool)
        rows = []
        for task_id in schedule.tolist():
            stops = self._stops.get(task_id)
            rows.append([] if stops is None else stops[pool[task_id].idx_next_loc :])
        width = max(map(len, rows), default=0) or 1
        return np.array([row + [-1] * (width - len(row)) for row in rows], dtype=np.int64)

    def opened(self, pool: Any, schedule: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: whether an errand of each robot's task in ``schedule`` (task ids,
        -1 none) is done (the kit's ``idx_next_loc`` past 0)."""
        self.update(pool)
        return np.array([task_id in self._stops and pool[task_id].idx_next_loc > 0
                         for task_id in schedule.tolist()], dtype=bool)  # fmt: skip

    def open_tasks(self, pool: Any, schedule: np.ndarray) -> OpenTasks:
        """The pool as :class:`~warehouse_phys.lorr.startkit.scheduler.OpenTasks`: a task's
        robot is the one ``schedule`` gives it (the kit's ``agent_assigned``)."""
        ids = self.update(pool)
        robot_of = {int(t): r for r, t in enumerate(schedule.tolist()) if t >= 0}
        firsts, lengths, robots = [], [], []
        cols = self.cols
        for task_id in ids:
            stops = self._stops[task_id]
            robot = robot_of.get(task_id, -1)
            done = pool[task_id].idx_next_loc if robot >= 0 else 0
            firsts.append(stops[done])
            lengths.append(self._lengths[task_id] if not done else _length(stops[done:], cols))
            robots.append(robot)
        arrays = [np.array(v, dtype=np.int64) for v in (ids, firsts, lengths, robots)]
        return OpenTasks(*arrays)


def _length(stops: list[int], cols: int) -> int:
    """The Manhattan length of a task's ``stops``, from the first to the last [moves]."""
    rows, columns = np.divmod(np.array(stops, dtype=np.int64), cols)
    return int(np.abs(np.diff(rows)).sum() + np.abs(np.diff(columns)).sum())


#: One :class:`TaskBook` a kit environment, and the queue walk its scheduler made for its
#: planner (the planner's call follows the scheduler's on the same environment).
_BOOKS: dict[int, TaskBook] = {}
_WALKS: dict[int, np.ndarray] = {}


def book_of(env: Any) -> TaskBook:
    """The :class:`TaskBook` of the kit's ``env``."""
    return _BOOKS.setdefault(id(env), TaskBook(env.cols))


class PlannerAdapter:
    """The kit's ``pyMAPFPlanner``: :class:`~warehouse_phys.lorr.startkit.planner.EntryPlanner`
    planning from the predicted states (``curr_states``) towards the errands of the
    proposed schedule (``curr_task_schedule``) left once the staged actions are done."""

    def __init__(self) -> None:
        self.env: Any = None
        self.core: EntryPlanner | None = None
        self._share: float | None = ROUND_SHARE

    def initialize(self, preprocess_time_limit: int) -> None:
        grid = kit_grid(self.env)
        name, guidance = setting("WAREHOUSE_PHYS_PLANNER"), entry_guidance()
        self._share = round_share()
        self.core = EntryPlanner(grid, steps=kit_steps(self.env), planner=name,
                                 guidance=guidance)  # fmt: skip
        self._ahead = neighbour_table(grid)[:, HEADING_MOVES]
        self._calls = 0
        # Load the compiled searches now (preprocessing has 30 s), not in the first plan (1 s).
        free = np.flatnonzero(grid.free_mask.reshape(-1))[:2]
        warm = EntryPlanner(grid, steps=1, planner=name, guidance=guidance)
        warm.plan(free, np.zeros(len(free), np.int64), free[::-1])

    @timed("plan")
    def plan(self, time_limit: int) -> list[list[int]]:
        env = self.env
        n = env.num_of_agents
        cells, headings = states_of(env.curr_states, n)
        schedule = np.array(list(env.curr_task_schedule), dtype=np.int64).reshape(-1)
        if len(schedule) != n:
            schedule = np.full(n, -1, dtype=np.int64)
        pool, book = env.task_pool, book_of(env)
        stops = book.stops_of(pool, schedule)
        if _SCHEDULERS and len(_SCHEDULERS[-1].held) == n:  # tasks held for robots
            held = _SCHEDULERS[-1].held
            first = book.stops_of(pool, held)[:, 0]  # a held task is not opened
            stops = with_held(stops, first)
        walk = _WALKS.pop(id(env), None)
        walk = queue_cells(env, self._ahead) if walk is None else walk
        goals = goals_after_queue(walk, stops)
        tick = None if not self._calls else int(env.system_timestep)  # the first: tick 0
        self._calls += 1
        steps = window_steps(tick, round_ticks(env), env.max_counter)
        begun = _ROUND_BEGUN[0] if _SCHEDULER.is_set() else time.perf_counter()
        seconds = None
        if self._share is not None:
            seconds = max(0.0, begun + self._share * time_limit / 1000 - time.perf_counter())
        actions = self.core.plan(cells, headings, goals, steps, seconds=seconds)
        _PLANNED[:] = [actions]  # the executor's next plan (see plan_table)
        return actions.tolist()


class SchedulerAdapter:
    """The kit's ``pyTaskScheduler``:
    :class:`~warehouse_phys.lorr.startkit.scheduler.EntryScheduler` on the task pool, the
    current schedule and the predicted states."""

    def __init__(self) -> None:
        self.env: Any = None
        self.core: EntryScheduler | None = None

    def initialize(self, preprocess_time_limit: int) -> None:
        grid = kit_grid(self.env)
        self.core = EntryScheduler(self.env.cols, setting("WAREHOUSE_PHYS_SCHEDULER"), grid)
        self._ahead = neighbour_table(grid)[:, HEADING_MOVES]
        _SCHEDULERS.append(self.core)
        _SCHEDULER.set()

    def plan(self, time_limit: int) -> list[int]:
        _ROUND_BEGUN[0] = time.perf_counter()
        answer = self._plan(time_limit)
        # Last, after the timing's file is written: the kit copies the answer before it
        # lets go of Python's lock, and the executor goes on once this is set.
        _SCHEDULED.set()
        return answer

    @timed("schedule")
    def _plan(self, time_limit: int) -> list[int]:
        env = self.env
        n = env.num_of_agents
        cells, _ = states_of(env.curr_states, n)
        current = np.array(list(env.curr_task_schedule), dtype=np.int64).reshape(-1)
        if len(current) != n:
            current = np.full(n, -1, dtype=np.int64)
        pool, book = env.task_pool, book_of(env)
        # Robots whose staged actions finish their task: a task is held for them.
        walk = _EXECUTED.pop() if _EXECUTED else None  # this interpreter's executor's
        if walk is None or len(walk) != n:
            walk = queue_cells(env, self._ahead)
        _WALKS[id(env)] = walk  # the planner's too
        remaining = book.stops_of(pool, current)
        after = goals_after_queue(walk, remaining)
        busy = current >= 0
        unopened = busy & ~book.opened(pool, current) & (after == remaining[:, 0])
        return self.core.schedule(current, cells, book.open_tasks(pool, current),
                                  busy & (after < 0), unopened).tolist()  # fmt: skip


def plan_table(actions: Any, n: int) -> np.ndarray:
    """``(N, S)`` the kit's plan ``actions`` (its ``Plan.actions``) as action numbers, waits
    (3) after a robot's last. The kit hands the executor the plan its planner answered:
    when this interpreter's planner made it, its own array is taken (the kit's ten
    thousand lists of actions cost a tenth of a second to read), once a few robots'
    actions, spread over the fleet, are checked to be the kit's; else the kit's are read."""
    if _PLANNED:
        table = _PLANNED.pop()
        if len(table) == n == len(actions) and table.shape[1]:
            probes = np.unique(np.linspace(0, n - 1, min(n, 16)).astype(np.int64)).tolist()
            if all([int(a) for a in actions[i]] == table[i].tolist() for i in probes):
                return table
    rows = [[int(a) for a in robot] for robot in actions]
    width = max(map(len, rows), default=0)
    table = np.full((n, width), 3, dtype=np.int64)
    for robot, row in enumerate(rows[:n]):
        table[robot, : len(row)] = row
    return table


class ExecutorAdapter:
    """The kit's ``pyExecutor``: :class:`~warehouse_phys.lorr.startkit.executor.EntryExecutor`
    (see the module for how a commanded tick is settled)."""

    def __init__(self) -> None:
        self.env: Any = None
        self.core: EntryExecutor | None = None
        #: Robots told GO that the kit's action model kept back (the executor allows none).
        self.refused = 0
        #: Rounds whose first command waited the whole while for the scheduler.
        self.scheduler_waits = 0
        self._go: np.ndarray | None = None
        self._round = False

    def initialize(self, preprocess_time_limit: int) -> None:
        self._grid = kit_grid(self.env)

    @timed("process_new_plan")
    def process_new_plan(self, sync_time_limit: int, plan: Any, staged_actions: Any) -> list:
        import MAPF

        env = self.env
        n = env.num_of_agents
        if self.core is None:  # the starts are known at the first plan
            starts, _ = states_of(env.system_states, n)
            self.core = EntryExecutor(self._grid, starts, env.max_counter,
                                      agent_size=float(setting("WAREHOUSE_PHYS_AGENT_SIZE")),
                                      horizon=kit_steps(env) + 1)  # fmt: skip
        self._settle()
        _SCHEDULED.clear()  # the kit starts the next round's scheduler after this call
        self._round = True
        table = plan_table(plan.actions, n)
        before = self._queue_lengths()
        try:
            self.core.process_new_plan(table)
        except ValueError as error:  # a plan the robots cannot make: keep the queues as they are
            print(f"warehouse_phys executor: plan not staged: {error}", file=sys.stderr)
        queue = self.core.executor.queue_actions()
        after = (queue >= 0).sum(axis=1)
        kinds = [MAPF.Action.FW, MAPF.Action.CR, MAPF.Action.CCR]
        # A new queue is a prefix of the old one and the plan: only robots whose length
        # changed change (the kit checks the prefix).
        for robot in np.flatnonzero(after != before).tolist():
            kept = min(int(before[robot]), int(after[robot]))
            staged = staged_actions[robot]
            if len(staged) > kept:
                del staged[kept:]
            staged.extend([kinds[code] for code in queue[robot, kept : after[robot]].tolist()])
        cells, headings = self.core.predicted()
        _EXECUTED[:] = [self.core.executor.queue_cells()]  # the round's walk (see _EXECUTED)
        return [MAPF.State(int(c), -1, int(h)) for c, h in zip(cells.tolist(), headings.tolist(),
                                                              strict=True)]  # fmt: skip

    @timed("next_command")
    def next_command(self, exec_time_limit: int) -> list[int]:
        if self.core is None:
            return [_STOP] * self.env.num_of_agents
        self._settle()
        if self._round and _SCHEDULER.is_set():
            self._round = False
            if not _SCHEDULED.wait(exec_time_limit * SCHEDULER_WAIT / 1000):  # [ms] -> [s]
                self.scheduler_waits += 1
                print("warehouse_phys executor: went on without the scheduler's answer "
                      f"({exec_time_limit * SCHEDULER_WAIT:.0f} ms)", file=sys.stderr)  # fmt: skip
        self._go = self.core.next_command()
        return np.where(self._go, _GO, _STOP).tolist()

    def _queue_lengths(self) -> np.ndarray:
        return (self.core.executor.queue_actions() >= 0).sum(axis=1)

    def _settle(self) -> None:
        """Settle the tick last commanded from the kit's states now (see the module)."""
        if self._go is None:
            return
        go, self._go = self._go, None
        executor = self.core.executor
        states = self.env.system_states
        robots = np.flatnonzero(go)
        delayed = np.zeros(len(go), dtype=bool)
        before = zip(robots.tolist(), executor.done[robots].tolist(),
                     executor.left[robots].tolist(), executor.headings[robots].tolist(),
                     strict=True)  # fmt: skip
        refused = 0
        for robot, done, cell, heading in before:
            state = states[robot]
            if state.delay.inDelay:
                delayed[robot] = True
            elif state.counter.count != done:  # read first: it moved for most robots
                continue
            elif (state.location, state.orientation) == (cell, heading):
                delayed[robot] = True  # told GO, not delayed, did not advance: refused
                refused += 1
        if refused:
            self.refused += refused
            print(f"warehouse_phys executor: the kit kept back {refused} robot(s) told GO",
                  file=sys.stderr)  # fmt: skip
        self.core.tick_done(delayed)
