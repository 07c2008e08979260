"""The entry's executor: the package's executor of square robots, as the start kit drives it.

The kit calls its executor twice over: ``process_new_plan`` with each plan (the actions
go on the end of the robots' staged actions; the executor answers where the robots will
stand once those are done, the *predicted states* the next plan starts from) and
``next_command`` every tick (GO or STOP a robot, before the tick's delays are drawn).
:class:`EntryExecutor` is :class:`~warehouse_phys.execution.queued.QueuedExecutor` with
the instance's squares (``agentSize``) behind those two calls: a plan is appended to the
queues and each queue cut to ``horizon`` actions (the kit's own executor keeps about as
many: what it can run before the next plan), and a tick's command is the executor's
:meth:`~warehouse_phys.execution.executor.Executor.command`, settled by
:meth:`EntryExecutor.tick_done` once the tick's delays are known (the kit's adapter does
it at its next call, from the delays the kit reports then). Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.execution.executor import TickCommand, TickReport
from warehouse_phys.execution.plan_checks import rows_cols
from warehouse_phys.execution.queued import QueuedExecutor, queue_path
from warehouse_phys.execution.ticks import check_whole
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, Heading
from warehouse_phys.world.traffic import neighbour_table


def plan_steps(comm_ms: int, tick_ms: int, ticks_per_move: int) -> int:
    """Actions a queue keeps: the kit's own ``min_plan_steps = planCommTimeLimit /
    (actionMoveTimeLimit * agentCounter) + 1``, the moves a robot makes between two plans,
    and one more (the most a robot on time holds, :func:`window_steps`)."""
    return int(comm_ms) // (int(tick_ms) * int(ticks_per_move)) + 1


def window_steps(tick: int | None, round_ticks: int, ticks_per_move: int) -> int:
    """Steps of the plan the entry computes at ``tick`` (``None``: its first, computed before
    tick 0 and staged at once; the others are staged a round later): the actions a robot
    that keeps to its plan makes between the tick the plan is staged and the next round's,
    ``ceil((tick + 2 R) / T) - ceil((tick + R) / T)`` for rounds of ``R`` ticks and moves
    of ``T`` (3, 3 and 4 in turn for 10 and 3; ``ceil(R / T)`` first). So a robot's queue
    lasts until the next plan and no longer, and the planner's steps are the robots'
    moves: the next plan starts where this one ends."""
    r, t = int(round_ticks), int(ticks_per_move)
    if tick is None:
        return -(-r // t)
    return -(-(int(tick) + 2 * r) // t) - -(-(int(tick) + r) // t)


class EntryExecutor:
    """Plans queued and ticks commanded for square robots, as the kit asks (see the module).

    Args:
        grid: The floor.
        starts: ``(N,)`` each robot's start (cell index); every robot faces east, as in
            the kit.
        ticks_per_move: Ticks a forward move or a quarter turn takes (``agentCounter``).
        agent_size: The robots' side [cells], in ``(0, 1]``.
        horizon: Actions kept in each robot's queue after a plan.

    Raises:
        ValueError, TypeError: naming the argument.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        starts: np.ndarray,
        ticks_per_move: int,
        *,
        agent_size: float = 1.0,
        horizon: int,
    ) -> None:
        starts = np.asarray(starts, dtype=np.int64)
        headings = np.full(len(starts), Heading.EAST, dtype=np.int64)
        self.executor = QueuedExecutor(grid, rows_cols(starts, grid.cols), ticks_per_move,
                                       headings=headings, agent_size=agent_size)  # fmt: skip
        self.horizon = check_whole("horizon", horizon, 1, 10**6)
        self._ahead = neighbour_table(grid)[:, HEADING_MOVES]
        self._command: TickCommand | None = None

    def process_new_plan(self, actions: np.ndarray) -> None:
        """Append ``actions`` (``(N, S)`` the kit's action numbers, planned from
        :meth:`predicted`) to the queues and cut each to ``horizon`` actions.

        Raises:
            RuntimeError: while a tick's command awaits :meth:`tick_done`.
            ValueError: for actions the robots cannot make (into a wall, two robots into
                one cell, ...), naming the robot and step.
        """
        self._settled()
        actions = np.asarray(actions, dtype=np.int64).reshape(len(self.executor.left), -1)
        self.executor.append_plan(queue_path(self.executor, actions, self._ahead))
        self.executor.truncate(self.horizon)

    def predicted(self) -> tuple[np.ndarray, np.ndarray]:
        """``(N,)`` cells and ``(N,)`` headings where the robots stand once their queues
        are done: the kit's predicted states."""
        cells, headings = self.executor.queue_end()
        return cells, headings

    def next_command(self) -> np.ndarray:
        """``(N,)`` bool, GO for each robot this tick (STOP for the others); the tick is
        settled by :meth:`tick_done`.

        Raises:
            RuntimeError: while the last command awaits :meth:`tick_done`.
        """
        self._settled()
        self._command = self.executor.command()
        return self._command.ready.copy()

    def tick_done(self, delayed: np.ndarray) -> TickReport:
        """Settle the commanded tick: ``delayed`` (``(N,)`` bool) did not advance, the rest
        that were told GO did.

        Raises:
            RuntimeError: without a command to settle.
        """
        if self._command is None:
            raise RuntimeError("tick_done() settles a next_command(): none is pending")
        command, self._command = self._command, None
        return self.executor.step(np.asarray(delayed, dtype=bool), command)

    @property
    def pending(self) -> bool:
        """Whether a command awaits :meth:`tick_done`."""
        return self._command is not None

    def _settled(self) -> None:
        if self._command is not None:
            raise RuntimeError("the last tick's command awaits tick_done() with its delays")
