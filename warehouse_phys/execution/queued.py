"""Plans that arrive late: an executor that appends each new plan after the actions it has
staged, as the League of Robot Runners' start kit runs an entry.

The start kit (2026) does not wait for the planner. Every ``planCommTimeLimit`` it hands
the executor the plan it asked for one round earlier, asks the executor where the robots
will stand once their staged actions are done (the *predicted states*), and starts the
planner on those; meanwhile the robots go on executing. A plan is therefore made from
where the robots *will* be, arrives while they are still on their way there, and must go
on the end of each robot's queue: the kit checks that the staged actions stay a prefix of
the old ones followed by the plan's.

:class:`QueuedExecutor` is the :class:`~warehouse_phys.execution.executor.Executor` (the
same dependency graph, follow rule and ticks) kept that way:

- :meth:`QueuedExecutor.append_plan` joins a plan made from
  :meth:`QueuedExecutor.queue_end` to the end of every robot's queue. A move into a cell
  depends, as ever, on the move by which the cell's previous holder leaves it: within the
  plan, the robot there at an earlier step; for a cell the plan's robots do not hold
  before, the last robot whose queued actions visit it (found by the order in which the
  visits were planned: every visit of a later plan comes after every visit of an earlier
  one). So every dependency points to an earlier plan or an earlier step, and the graph
  stays free of cycles across plans.
- :meth:`QueuedExecutor.truncate` cuts each robot's queue to at most ``horizon`` actions,
  and then every action that depends on one cut, until none does (the start kit's own
  executor likewise keeps only what it can run before the next plan): a robot that fell
  behind its plan (delayed) stops where its kept actions end, and the next plan starts
  from there; the cells left are still distinct, as no kept move enters a cell whose
  previous holder's leaving move was cut.
- Moves are released at once (the plans' times are not the robots': a plan's wait only
  orders robots, which the graph does).

:meth:`QueuedExecutor.queue_end` is where each robot's next plan starts (its predicted
state) and :meth:`QueuedExecutor.queue_actions` its staged actions, in the kit's
numbering (forward 0, clockwise 1, counter-clockwise 2). With square robots
(``agent_size``) a tick's command does not depend on the tick's delays
(:meth:`~warehouse_phys.execution.executor.Executor.command`): what the kit asks of an
executor. The cost of an append or a truncation is O(N W) array operations for queues of
``W`` actions (a truncation loops once for each link of the longest chain of cuts). Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.execution.executor import _AT_ONCE, Executor, _Moves
from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.execution.plan_checks import (
    NO_ROBOT,
    check_plan,
    check_turns,
    checked_path,
    rows_cols,
)
from warehouse_phys.execution.ticks import check_whole
from warehouse_phys.world.grid import WarehouseGrid

#: A cell's visit by no robot, and the order key of a robot's visit before any plan.
_NOBODY, _FIRST = -1, np.iinfo(np.int64).min
#: The kit's action numbers of a queue (``MAPF.Action``): forward, clockwise,
#: counter-clockwise; :data:`NO_ACTION` pads the rows.
FORWARD, CLOCKWISE, COUNTERCLOCKWISE, NO_ACTION = 0, 1, 2, -1


class QueuedExecutor(Executor):
    """The executor with plans appended to queues of staged actions (see the module).

    Args: as :class:`~warehouse_phys.execution.executor.Executor`'s.

    :meth:`add_plan` is :meth:`append_plan` here: a plan starts from :meth:`queue_end`,
    not from :meth:`plan_cells`.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        cells: np.ndarray,
        ticks_needed: np.ndarray | int = 1,
        min_gap: float = DEFAULT_MIN_GAP,
        headings: np.ndarray | None = None,
        agent_size: float | None = None,
    ) -> None:
        super().__init__(grid, cells, ticks_needed, min_gap, headings, agent_size)
        n = len(self.left)
        #: The order key of each queued action's plan and step (later plans: larger).
        self._key = np.zeros((n, 1), dtype=np.int64)
        #: Plans appended so far.
        self.plans = 0
        self._step_keys = 0

    # ------------------------------------------------------------------ the queue
    def queue_end(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``(N,)`` the cell index where each robot stands once its queue is done, and
        turning robots' ``(N,)`` heading then (``None`` for four-direction robots)."""
        robots, moves = self._robots, self._moves
        last = np.maximum(self._count - 1, 0)
        queued = self._count > self._next
        cell = np.where(queued, moves.to[robots, last], self.entered)
        if self.facing is None:
            return cell, None
        return cell, np.where(queued, moves.face[robots, last], self.facing)

    def queue_actions(self) -> np.ndarray:
        """``(N, W)`` each robot's queued actions in order, the one in progress first:
        :data:`FORWARD`, :data:`CLOCKWISE`, :data:`COUNTERCLOCKWISE` (four-direction
        robots: :data:`FORWARD` for every move), padded with :data:`NO_ACTION`."""
        cells, faces = self._queue_positions()
        width = cells.shape[1] - 1
        actions = np.full((len(cells), width), NO_ACTION, dtype=np.int64)
        k = np.arange(width)[None, :]
        queued = (k >= self._next[:, None]) & (k < self._count[:, None])
        forward = cells[:, 1:] != cells[:, :-1]
        actions[queued & forward] = FORWARD
        if faces is not None:
            turn = (faces[:, 1:] - faces[:, :-1]) % 4
            actions[queued & ~forward & (turn == 1)] = CLOCKWISE
            actions[queued & ~forward & (turn == 3)] = COUNTERCLOCKWISE
        # Left-align each row: the action in progress (or next) first.
        shift = (k + self._next[:, None]).clip(max=width - 1)
        shifted = np.take_along_axis(actions, shift, axis=1)
        return np.where(k < (self._count - self._next)[:, None], shifted, NO_ACTION)

    def queue_cells(self) -> np.ndarray:
        """``(N, W + 1)`` the cell each robot stands on (or leaves) now, then after each of
        its queued actions; the rows padded with their last cell."""
        cells, _ = self._queue_positions()
        k = np.arange(cells.shape[1])[None, :]
        start = self._next[:, None]
        index = np.minimum(k + start, self._count[:, None]).clip(max=cells.shape[1] - 1)
        return np.take_along_axis(cells, index, axis=1)

    # ------------------------------------------------------------------ plans
    def add_plan(self, path: np.ndarray) -> None:
        """:meth:`append_plan` (a queued executor appends)."""
        self.append_plan(path)

    def append_plan(self, path: np.ndarray) -> None:
        """Append a lock-step plan to every robot's queue.

        Args:
            path: ``(N, S + 1, 2)`` each robot's ``(row, col)`` at steps ``0..S``, step 0
                being :meth:`queue_end` (turning robots: ``(N, S + 1, 3)``, ``(row, col,
                heading)``), checked as :meth:`Executor.add_plan
                <warehouse_phys.execution.executor.Executor.add_plan>` checks a plan: moves
                to free neighbours, no two robots in a cell or across an edge, no rotation
                the robots cannot make (none for square robots), turns a quarter in place.

        Raises:
            ValueError: naming ``path`` and the first robot and step that break this.
        """
        n = len(self._robots)
        cells, faces = checked_path(self.grid, path, n, self.facing is not None)
        end, end_faces = self.queue_end()
        wrong = np.flatnonzero(cells[:, 0] != end)
        if wrong.size:
            i = int(wrong[0])
            raise ValueError(f"path must start from queue_end(): robot {i} starts at "
                             f"{divmod(int(cells[i, 0]), self.grid.cols)}, not "
                             f"{divmod(int(end[i]), self.grid.cols)}")  # fmt: skip
        rotating = check_plan(cells, end, self._table, self._needed, self.grid, self.min_gap,
                              squares=self.agent_size is not None)  # fmt: skip
        if faces is not None:
            check_turns(cells, faces, end_faces, self.grid.cols)
        self._compact()
        holder, leave = self._holders()
        acted = cells[:, 1:] != cells[:, :-1]
        if faces is not None:
            acted |= faces[:, 1:] != faces[:, :-1]
        self._grow(int((self._count + acted.sum(axis=1)).max()))
        self._append(cells, faces, acted, holder, leave)
        i, s = np.nonzero(rotating.T)  # rotations (discs only): each goes as one
        if i.size:
            number = self._count_before[:, None] + np.cumsum(acted, axis=1) - 1
            self._moves.rotation[i, number[i, s]] = True
        self.plans += 1

    def truncate(self, horizon: int) -> None:
        """Keep at most ``horizon`` queued actions a robot (its action in progress among
        them), and no action that depends on one cut (see the module).

        Raises:
            TypeError, ValueError: for a ``horizon`` that is not an integer of at least 1.
        """
        horizon = check_whole("horizon", horizon, 1, 10**9)
        moves = self._moves
        keep = np.minimum(self._count, self._next + horizon)
        k = np.arange(moves.width)[None, :]
        leader = np.where(moves.dep_robot == NO_ROBOT, 0, moves.dep_robot)
        for _ in range(len(self._robots) + 1):
            kept = (k >= self._next[:, None]) & (k < keep[:, None])
            cut = kept & (moves.dep_robot != NO_ROBOT) & (moves.dep_move >= keep[leader])
            if not cut.any():
                break
            first = np.where(cut.any(axis=1), cut.argmax(axis=1), moves.width)
            keep = np.minimum(keep, first)
        self._count = keep

    # ------------------------------------------------------------------ parts
    def _queue_positions(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``(N, W + 1)`` cells and headings before each column's action and after the
        last: column 0 is where the robot is (or leaves) before its queue's first
        unfinished action; finished columns are not meaningful."""
        moves = self._moves
        cells = np.concatenate([self.left[:, None], moves.to], axis=1)
        k = np.arange(moves.width + 1)[None, :]
        # Before the action in progress or next: the robot's own cell (the one it leaves).
        first = self._next[:, None]
        cells = np.where(k == first, self.left[:, None], cells)
        cells = np.where(k > self._count[:, None], cells[np.arange(len(cells)),
                         np.minimum(self._count, moves.width)][:, None], cells)  # fmt: skip
        if self.facing is None:
            return cells, None
        faces = np.concatenate([self.headings[:, None], moves.face], axis=1)
        faces = np.where(k == first, self.headings[:, None], faces)
        last = np.minimum(self._count, moves.width)
        faces = np.where(k > self._count[:, None], faces[np.arange(len(faces)), last][:, None],
                         faces)  # fmt: skip
        return cells, faces

    def _compact(self) -> None:
        """Drop every robot's finished actions: its next unfinished one becomes column 0;
        dependencies renumbered (a negative one is met)."""
        shift = self._next.copy()
        if not shift.any():
            return
        moves, width = self._moves, self._moves.width
        index = (np.arange(width)[None, :] + shift[:, None]).clip(max=width - 1)
        fields = [np.take_along_axis(array, index, axis=1) for array in moves]
        compact = _Moves(*fields)
        has = compact.dep_robot != NO_ROBOT
        compact.dep_move[has] -= shift[compact.dep_robot[has]]
        self._moves = compact
        self._key = np.take_along_axis(self._key, index, axis=1)
        self._count = self._count - shift
        self._next = np.zeros_like(self._next)

    def _grow(self, width: int) -> None:
        """Widen the move arrays to ``width`` columns (at least)."""
        moves = self._moves
        extra = width - moves.width
        if extra <= 0:
            return
        blank = _Moves.empty(len(self._robots), extra)
        self._moves = _Moves(*(np.concatenate([old, new], axis=1)
                               for old, new in zip(moves, blank, strict=True)))  # fmt: skip
        self._key = np.concatenate([self._key, np.zeros((len(self._robots), extra), np.int64)],
                                   axis=1)  # fmt: skip

    def _holders(self) -> tuple[np.ndarray, np.ndarray]:
        """For every cell, the robot whose queue visits it last (``_NOBODY`` for none) and
        the number of that robot's move out of it (``-1``: it stays there)."""
        cells, _ = self._queue_positions()
        n, width = len(self._robots), self._moves.width
        k = np.arange(width + 1)[None, :]
        visit = (k >= self._next[:, None]) & (k <= self._count[:, None])
        entering = np.zeros_like(visit)
        entering[:, 1:] = cells[:, 1:] != cells[:, :-1]
        # A visit starts where the robot is now or where a move enters a cell.
        starts = visit & (entering | (k == self._next[:, None]))
        keys = np.concatenate([np.full((n, 1), _FIRST), self._key], axis=1)
        keys = np.where(k == self._next[:, None], _FIRST, keys)
        # Its leaving move: the robot's next forward move after it, if queued.
        forward = np.zeros_like(visit)
        forward[:, :-1] = (cells[:, 1:] != cells[:, :-1]) & visit[:, 1:]
        forward &= k < self._count[:, None]
        after = np.where(forward, k, width + 1)
        leave = np.minimum.accumulate(after[:, ::-1], axis=1)[:, ::-1]  # first forward >= k
        robot, column = np.nonzero(starts)
        leaves = leave[robot, column]
        order = np.lexsort((keys[robot, column], cells[robot, column]))
        cell = cells[robot, column][order]
        last = np.append(cell[1:] != cell[:-1], True)
        holder = np.full(self.grid.rows * self.grid.cols, _NOBODY, dtype=np.int64)
        out = np.full_like(holder, -1)
        holder[cell[last]] = robot[order][last]
        gone = leaves[order][last]
        out[cell[last]] = np.where(gone <= width, gone, -1)
        return holder, out

    def _append(
        self,
        cells: np.ndarray,
        faces: np.ndarray | None,
        acted: np.ndarray,
        holder: np.ndarray,
        leave: np.ndarray,
    ) -> None:
        """Write a checked plan's actions after each robot's queue, with their
        dependencies (see the module)."""
        moves = self._moves
        n, steps = cells.shape[0], cells.shape[1] - 1
        self._count_before = self._count.copy()
        number = np.zeros((n, steps + 1), dtype=np.int64)
        number[:, 1:] = self._count[:, None] + np.cumsum(acted, axis=1) - 1
        i, s = np.nonzero(acted)
        s = s + 1
        k = number[i, s]
        moves.to[i, k] = cells[i, s]
        moves.release[i, k] = _AT_ONCE
        moves.dep_robot[i, k] = NO_ROBOT
        moves.rotation[i, k] = False
        if faces is not None:
            moves.face[i, k] = faces[i, s]
        self._step_keys += steps + 1
        self._key[i, k] = self._step_keys + s
        # The previous visit of each cell entered, within the plan: sorted by cell, step.
        order = np.lexsort((np.tile(np.arange(steps + 1), n), cells.ravel()))
        previous = np.full(cells.size, -1, dtype=np.int64)
        same = cells.ravel()[order[1:]] == cells.ravel()[order[:-1]]
        previous[order[1:][same]] = order[:-1][same]
        entering = cells[i, s] != cells[i, s - 1]
        before = previous[i * (steps + 1) + s]
        j, s_before = np.divmod(before, steps + 1)
        inside = entering & (before >= 0) & (j != i)
        moves.dep_robot[i[inside], k[inside]] = j[inside]
        moves.dep_move[i[inside], k[inside]] = number[j[inside], s_before[inside] + 1]
        # A cell first held in this plan waits for its last holder in the queues.
        first = entering & (before < 0)
        was = holder[cells[i[first], s[first]]]
        out = leave[cells[i[first], s[first]]]
        other = (was != _NOBODY) & (was != i[first])
        if (other & (out < 0)).any():  # the holder stays: it would be in the plan at step 0
            raise AssertionError("a queue ends on a cell that the plan does not start on")
        moves.dep_robot[i[first][other], k[first][other]] = was[other]
        moves.dep_move[i[first][other], k[first][other]] = out[other]
        self._count = self._count + acted.sum(axis=1)


def queue_path(executor: QueuedExecutor, actions: np.ndarray, moves_of: np.ndarray) -> np.ndarray:
    """The lock-step plan of ``actions`` (``(N, S)`` turning actions in the kit's numbering:
    forward 0, clockwise 1, counter-clockwise 2, anything else a wait) from
    ``executor``'s :meth:`~QueuedExecutor.queue_end`, for :meth:`~QueuedExecutor.append_plan`:
    ``(N, S + 1, 3)`` ``(row, col, heading)``. ``moves_of`` is the floor's
    ``(rows * cols, 4)`` neighbour of each cell along each heading (itself where a wall is).

    Raises:
        ValueError: for a forward move into a wall or off the floor, naming the robot.
    """
    cell, face = executor.queue_end()
    if face is None:
        raise ValueError("queue_path: turning robots only (the executor has no headings)")
    actions = np.asarray(actions, dtype=np.int64)
    n, steps = actions.shape
    path = np.empty((n, steps + 1, 2), dtype=np.int64)
    path[:, 0, 0], path[:, 0, 1] = cell, face
    for s in range(steps):
        act = actions[:, s]
        wall = (act == FORWARD) & (moves_of[cell, face] == cell)
        if wall.any():
            raise ValueError(f"actions drive robot {int(np.flatnonzero(wall)[0])} into a wall "
                             f"or off the floor at step {s + 1}")  # fmt: skip
        cell = np.where(act == FORWARD, moves_of[cell, face], cell)
        face = (
            face + np.where(act == CLOCKWISE, 1, 0) - np.where(act == COUNTERCLOCKWISE, 1, 0)
        ) % 4
        path[:, s + 1, 0], path[:, s + 1, 1] = cell, face
    rc = rows_cols(path[..., 0], executor.grid.cols)
    return np.concatenate([rc, path[..., 1:]], axis=2)
