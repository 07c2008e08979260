"""The start kit's simulation loop restated: the entry run by the kit's rules, without the kit.

The start kit 3.1.0 (``BaseSystem::simulate`` and ``Simulator::move``) runs an entry
like this, one *tick* (``actionMoveTimeLimit``, 100 ms) at a time:

- Before tick 0 the entry computes its first schedule and plan from the robots' starts.
- Every *round* (``planCommTimeLimit / actionMoveTimeLimit`` ticks, 10 by default, when
  the entry keeps to its time) the kit takes the schedule the entry computed last
  (:meth:`~warehouse_phys.lorr.startkit.tasks.KitTasks.assign`, after its checks), hands
  the plan computed last to the executor (``process_new_plan``: the actions go after the
  staged ones; it answers the predicted states), and starts the entry's next
  computation from there: the scheduler, then the planner towards the proposed tasks.
  That plan arrives at the next round.
- Every tick the executor says GO or STOP to each robot (``next_command``); then the
  kit draws the tick's delays; a robot told GO and not delayed advances one tick of its
  first staged action; the action model refuses any motion whose square would collide
  with another's (``agentSize``); a robot finishes an errand at the end of a tick on which
  it stands on it, and a robot whose task ends is free for the round after.

:class:`KitSystem` is that loop over the entry's own parts
(:class:`~warehouse_phys.lorr.startkit.scheduler.EntryScheduler`,
:class:`~warehouse_phys.lorr.startkit.planner.EntryPlanner`,
:class:`~warehouse_phys.lorr.startkit.executor.EntryExecutor`, the same objects the kit's
adapters drive) with the computations taken as on time. Each tick it checks the squares
by the kit's rule (:func:`~warehouse_phys.execution.swept_squares.colliding_pairs`: the
collisions the kit's action model would report; the executor promises none), and it
records the kit's 2026 output file (:mod:`warehouse_phys.lorr.output_2026`). Its delays
are drawn by :class:`~warehouse_phys.execution.delays.DelayGenerator` (the kit's model, not
its random stream) or replayed from a kit run
(:class:`~warehouse_phys.execution.delay_replay.DelayReplay`): then, as long as the kit's
run had no timeout, the two runs are the same run.

What it leaves out: time. The kit runs in real time: an entry late with its plan shifts
the rounds, and an executor over its 100 ms adds ticks in which every robot waits; here
neither happens. Like :mod:`warehouse_phys.world.grid`, this module imports neither
gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.execution.delays import DelayConfig, DelayGenerator
from warehouse_phys.execution.swept_squares import colliding_pairs, square_corners
from warehouse_phys.execution.ticks import LORR_TICKS_PER_MOVE, check_ticks_per_move, check_whole
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.output_2026 import (
    CLOCKWISE,
    COUNTERCLOCKWISE,
    FORWARD,
    WAIT,
    Output2026,
    SegmentedPaths,
)
from warehouse_phys.lorr.startkit.executor import EntryExecutor, plan_steps, window_steps
from warehouse_phys.lorr.startkit.planner import (
    ENTRY_PLANNERS,
    EntryPlanner,
    goals_after_queue,
    with_held,
)
from warehouse_phys.lorr.startkit.scheduler import EntryScheduler
from warehouse_phys.lorr.startkit.tasks import KitTasks

#: The kit's default time limits [ms]: a plan's round and a tick (``planCommTimeLimit``,
#: ``actionMoveTimeLimit``).
COMM_MS, TICK_MS = 1000, 100


@dataclass
class TickOutcome:
    """What one tick of a :class:`KitSystem` did."""

    #: Errands and tasks finished at its end.
    errands: int
    tasks: int
    #: Pairs of robots whose squares collided by the kit's rule (the executor allows none).
    collisions: np.ndarray
    #: Whether a round began at it (the entry computed), and the CPU time of that [s].
    round_seconds: float | None
    #: The executor's report.
    report: Any


class KitSystem:
    """An instance run by the start kit's rules with the package's entry (see the module).

    Args:
        instance: A 2024 or later instance (a scheduler hands its tasks out).
        planner: The entry's planner by name
            (:func:`~warehouse_phys.lorr.startkit.planner.entry_planner`).
        guidance: Fields of its guidance and repair (``WAREHOUSE_PHYS_GUIDANCE`` in the
            kit; None: the entry's own).
        scheduler: The entry's scheduler (a name of
            :data:`~warehouse_phys.lorr.startkit.scheduler.ENTRY_SCHEDULERS`).
        ticks_per_move: Ticks a forward move or a quarter turn takes (default: the
            instance's ``agentCounter``, else the kit's 10).
        delays: A :class:`~warehouse_phys.execution.delays.DelayConfig` to draw from, a
            :class:`~warehouse_phys.execution.delay_replay.DelayReplay`, or ``None``
            (default: the instance's ``delayConfig``, none without one).
        comm_ms, tick_ms: The kit's ``planCommTimeLimit`` and ``actionMoveTimeLimit``
            [ms]: a round is ``ceil(comm_ms / tick_ms)`` ticks.
        seed: The planner's seed.
        check_squares: Check every tick's squares by the kit's rule (O(N log N) a tick).
        horizon: Actions a robot's queue keeps after a plan (default: one more than a
            robot on time holds, :func:`~warehouse_phys.lorr.startkit.executor.plan_steps`).

    Raises:
        ValueError, TypeError: naming the argument.
    """

    def __init__(
        self,
        instance: LorrInstance,
        *,
        planner: str = ENTRY_PLANNERS[0],
        guidance: Mapping[str, Any] | None = None,
        scheduler: str = "assignment",
        ticks_per_move: int | None = None,
        delays: DelayConfig | DelayReplay | None = None,
        comm_ms: int = COMM_MS,
        tick_ms: int = TICK_MS,
        seed: int = 0,
        check_squares: bool = True,
        horizon: int | None = None,
    ) -> None:
        self.instance = instance
        grid = instance.grid
        counter = ticks_per_move or instance.agent_counter or LORR_TICKS_PER_MOVE
        self.ticks_per_move = check_ticks_per_move(counter)
        self.agent_size = 1.0 if instance.agent_size is None else float(instance.agent_size)
        comm_ms = check_whole("comm_ms", comm_ms, 1, 10**7)
        tick_ms = check_whole("tick_ms", tick_ms, 1, 10**7)
        #: Ticks between two rounds.
        self.round_ticks = -(-comm_ms // tick_ms)
        steps = plan_steps(comm_ms, tick_ms, self.ticks_per_move)
        self.tasks = KitTasks(instance, record=True)
        self._parts = (scheduler, planner, seed, steps, guidance)
        EntryScheduler(grid.cols, scheduler, grid)  # checked here: reset() builds the parts
        EntryPlanner(grid, steps=steps, planner=planner, seed=seed, guidance=guidance)
        self._executor_args = (grid, instance.starts, self.ticks_per_move)
        #: Actions a queue keeps: a robot on time holds at most ``steps`` (one round's
        #: moves and one in progress); one more, and only a robot behind is cut.
        self._horizon = horizon or steps + 1
        self.delay_config = instance.delay if delays is None else delays
        if self.delay_config is not None and not isinstance(
            self.delay_config, (DelayConfig, DelayReplay)
        ):
            raise TypeError(f"delays must be a DelayConfig, a DelayReplay or None, got "
                            f"{type(delays).__name__}")  # fmt: skip
        self.check_squares = bool(check_squares)
        self.reset()

    @property
    def grid(self) -> Any:
        """The floor."""
        return self.instance.grid

    @property
    def num_robots(self) -> int:
        return self.instance.team_size

    # ------------------------------------------------------------------ the run
    def reset(self) -> None:
        """Tick 0: robots on their starts facing east, the first tasks open, the entry's
        first schedule and plan computed."""
        grid, starts, counter = self._executor_args
        scheduler, planner, seed, steps, guidance = self._parts
        self.scheduler = EntryScheduler(grid.cols, scheduler, grid)
        self.planner = EntryPlanner(grid, steps=steps, planner=planner, seed=seed,
                                    guidance=guidance)  # fmt: skip
        self.executor = EntryExecutor(grid, starts, counter, agent_size=self.agent_size,
                                      horizon=self._horizon)  # fmt: skip
        config = self.delay_config
        if isinstance(config, DelayReplay):
            config.rewind()
            self.delays: DelayGenerator | DelayReplay | None = config
        else:
            self.delays = None if config is None else DelayGenerator(config, len(starts))
        self.tasks.reset(np.asarray(starts, dtype=np.int64))
        self.tick = 0
        n = len(starts)
        self.paths = SegmentedPaths(n)
        self.collisions: list[list[Any]] = []
        self.round_seconds: list[float] = []
        self._proposal, self._plan = self._compute(None)

    def step(self) -> TickOutcome:
        """One tick of the kit's loop (see the module)."""
        executor = self.executor.executor
        round_seconds = None
        if self.tick % self.round_ticks == 0:
            begun = time.process_time()
            self.tasks.assign(self._proposal)
            self.executor.process_new_plan(self._plan)
            self._proposal, self._plan = self._compute(self.tick)
            round_seconds = time.process_time() - begun
            self.round_seconds.append(round_seconds)
        left, entered, done = executor.left.copy(), executor.entered.copy(), executor.done.copy()
        headings = executor.headings.copy()
        go = self.executor.next_command()
        n = len(left)
        delayed = self.delays.next_tick() if self.delays is not None else np.zeros(n, bool)
        report = self.executor.tick_done(delayed)
        cols = self.instance.grid.cols
        self.paths.add(_letters(report, left, headings), *np.divmod(left, cols), headings, done)
        pairs = np.zeros((0, 2), dtype=np.int64)
        if self.check_squares:
            moving = np.where(done > 0, entered, report.heading)
            start = square_corners(left, moving, done, executor.ticks_needed, cols)
            end = square_corners(executor.left, executor.entered, executor.done,
                                 executor.ticks_needed, cols)  # fmt: skip
            pairs = colliding_pairs(start, end, left, self.agent_size, cols)
            self.collisions += [[int(a), int(b), self.tick + 1, "squares collide"]
                                for a, b in pairs.tolist()]  # fmt: skip
        tasks = self.tasks
        here = executor.left
        arrived = np.flatnonzero((tasks.goals >= 0) & (here == tasks.goals))
        errands_before, tasks_before = tasks.errands_done, tasks.tasks_done
        finished = tasks.step(arrived, here)
        self._proposal[finished] = -1  # the kit frees a robot whose task ends
        self.tick += 1
        del go
        return TickOutcome(tasks.errands_done - errands_before, tasks.tasks_done - tasks_before,
                           pairs, round_seconds, report)  # fmt: skip

    def run(self, ticks: int, on_tick: Callable[[TickOutcome], Any] | None = None) -> None:
        """Run ``ticks`` ticks from where the system is, calling ``on_tick`` after each."""
        for _ in range(check_whole("ticks", ticks, 0, 10**9)):
            outcome = self.step()
            if on_tick is not None:
                on_tick(outcome)

    def output(self) -> Output2026:
        """The kit's 2026 output file of the run so far."""
        instance, tasks = self.instance, self.tasks
        cols = instance.grid.cols
        paths = self.paths.strings()
        events = tasks.events
        intervals = ([[] for _ in range(instance.team_size)] if self.delays is None
                     else self.delays.intervals_json())  # fmt: skip
        return Output2026(
            team_size=instance.team_size, tasks_finished=tasks.tasks_done, ticks=self.tick,
            agent_max_counter=self.ticks_per_move, delay_intervals=intervals,
            starts=[list(divmod(int(s), cols)) for s in instance.starts.tolist()],
            actual_paths=paths, planner_paths=paths,
            events=[list(event) for event in events.finished],
            tasks=[[task, step, [int(v) for stop in instance.task(line).tolist()
                                 for v in divmod(stop, cols)]]
                   for task, step, line in events.revealed],
            errors=self.collisions,
            actual_schedule=_schedule_strings(tasks.actual_schedule),
            planner_schedule=_schedule_strings(tasks.planner_schedule),
            schedule_errors=tasks.schedule_errors,
            planner_times=list(self.round_seconds),
        )  # fmt: skip

    # ------------------------------------------------------------------ parts
    def _compute(self, tick: int | None) -> tuple[np.ndarray, np.ndarray]:
        """The entry's computation at a round (``tick``; ``None`` before tick 0): the
        scheduler's proposal (robots on their way to a task not opened paired again),
        then the planner's plan towards the proposed tasks (and the
        tasks held for robots about to be free), from the predicted states, of
        :func:`~warehouse_phys.lorr.startkit.executor.window_steps` steps."""
        cells, headings = self.executor.predicted()
        tasks = self.tasks
        queue = self.executor.executor.queue_cells()
        remaining = tasks.remaining_stops()
        after = goals_after_queue(queue, remaining)
        busy = tasks.tasks >= 0
        finishing = busy & (after < 0)
        unopened = busy & (tasks.progress == 0) & (after == remaining[:, 0])
        proposal = self.scheduler.schedule(tasks.tasks, cells, tasks.open_tasks(), finishing,
                                           unopened)  # fmt: skip
        stops = _proposed_stops(tasks, proposal, self.scheduler.held)
        goals = goals_after_queue(queue, stops)
        steps = window_steps(tick, self.round_ticks, self.ticks_per_move)
        return proposal, self.planner.plan(cells, headings, goals, steps)


def _proposed_stops(tasks: KitTasks, proposal: np.ndarray, held: np.ndarray) -> np.ndarray:
    """``(N, M + 1)`` the errands still to do of each robot's proposed task (a task it
    keeps: from its progress; a new one: all), then the first errand of the task held for
    it, padded with -1."""
    stops = tasks.remaining_stops()
    instance = tasks.instance
    new = np.flatnonzero((proposal >= 0) & (proposal != tasks.tasks))
    if new.size:
        lines = proposal[new] % instance.num_tasks
        first = instance.task_offsets[lines]
        size = instance.stops_per_task[lines]
        k = np.arange(stops.shape[1])[None, :]
        index = np.minimum(first[:, None] + k, len(instance.task_stops) - 1)
        stops[new] = np.where(k < size[:, None], instance.task_stops[index], -1)
    stops[proposal < 0] = -1
    held_stop = np.full(len(held), -1, dtype=np.int64)
    holding = np.flatnonzero(held >= 0)
    lines = held[holding] % instance.num_tasks
    held_stop[holding] = instance.task_stops[instance.task_offsets[lines]]
    return with_held(stops, held_stop)


def _letters(report: Any, left: np.ndarray, headings: np.ndarray) -> np.ndarray:
    """The kit's action number each robot took this tick: its action's (forward, a turn)
    where it advanced, a wait elsewhere."""
    actions = np.full(len(left), WAIT, dtype=np.int8)
    advanced = report.advanced
    forward = advanced & (report.heading != left)
    turn = (report.facing - headings) % 4
    actions[advanced & ~forward & (turn == 1)] = CLOCKWISE
    actions[advanced & ~forward & (turn == 3)] = COUNTERCLOCKWISE
    actions[forward] = FORWARD
    return actions


def _schedule_strings(logs: list[list[tuple[int, int]]]) -> list[str]:
    """The kit's schedule strings: ``"tick:task,tick:task"`` a robot."""
    return [",".join(f"{tick}:{task}" for tick, task in log) for log in logs]
