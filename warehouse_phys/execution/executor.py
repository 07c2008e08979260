"""Asynchronous execution of a fleet's plans: a dependency graph that keeps them safe under delays.

A planner (:class:`~warehouse_phys.planners.pibt.PIBT`) plans in lock step: every robot
makes one move, or waits, per *step*. Real robots do not keep step: a move takes
``ticks_needed`` ticks of the clock (one robot may be slower than another) and a robot
can be *delayed* for a tick (a person in the way, a wheel slipping), which stops it
where it is. :class:`Executor` runs lock-step plans on such robots without ever letting
two of them hold one cell: an Action Dependency Graph (Hoenig, Kiesel, Tinka, Durham
and Ayanian, "Persistent and robust execution of MAPF schedules in warehouses", RA-L
2019), kept as arrays.

**Ticks.** Between two ticks a robot is either *at rest* on a cell or *in mid-move*
between the cell it left and the cell it enters, some ticks of its move done. Its
*centre* is then that share of the way from the one cell's centre to the other's, and
within a tick it moves linearly (the grid twin's nominal position, which the physics
twin's bodies track). Each tick the executor says GO or STOP to every robot; a GO
robot that is not delayed advances one tick of its move (starting it if it was at
rest); a move ends after ``ticks_needed`` ticks, and the robot is at rest on the cell
it entered.

**The graph.** :meth:`Executor.add_plan` turns a plan, each robot's cells step by
step, into per-robot sequences of moves (a planned wait is no action; it only delays
the robot's next move, below) with one dependency each: a robot's move into cell ``c``
depends on the move by which ``c``'s previous planned holder, its *leader*, leaves it
(Hoenig's type-2 edge; the holders before that left before that one came, so one edge
suffices), and on the robot's own earlier moves (type-1: the sequence is done in
order).

**Following.** The Action Dependency Graph of the paper lets a robot start into ``c``
only once its leader has left ``c``. Here a robot may *follow* its leader into ``c``
while the leader is leaving it, keeping its centre at least :attr:`Executor.min_gap`
from the leader's all the time: straight behind, the gap is one cell plus the share of
its move the leader is ahead; round a corner, ``sqrt(l**2 + (1 - f)**2)`` for leader
and follower ``l`` and ``f`` of the way through their moves; and a follower ends its
move on ``c`` only as, or after, its leader's move out of ``c`` ends (so a robot at rest
holds its cell alone, and one robot at a time leaves a cell). In a tick a follower goes
GO when the gap holds all tick with its leader standing still (the leader must already
be in mid-move: nobody closes in on a robot at rest), or when it holds with both
advancing and the leader does advance: then the follower goes only if the leader goes.
Those hand-overs form chains (the leader may itself follow); the chain goes only if its
head does, decided by pointer doubling, and a closed chain (a *rotation*: robots each
entering the cell the next one leaves) goes in one tick when none of its robots is
delayed. So a line of robots whose moves take the same ticks moves as one, one cell
apart, as in lock step; a delayed robot stops those behind it only as they close in.
The gap rule is :func:`~warehouse_phys.execution.following.may_follow`.

**Plan times.** A move is *released* at the tick the plan meant it to start: a robot's
plan starts when its current move ends, and step ``s`` of it is ``s`` moves of its
``ticks_needed`` later. A move never starts before its release, so a robot never runs
ahead of its plan, and a robot that fell behind catches up over its planned waits.
*Drift* (:meth:`Executor.drift`) is how many ticks a robot is behind its plan.

**New plans** (every ``plan_every`` ticks, while robots keep executing):
:meth:`Executor.plan_cells` is where each robot's new plan starts, the cell its current
move ends in (its own cell at rest). :meth:`Executor.add_plan` *replaces* the moves not
yet started with the new plan's; moves in progress continue and become each robot's
first move; the first planned holder of a cell that a robot in mid-move is leaving
depends on that move. The new plan is checked against these cells (no two robots in one
cell, no swap, moves to neighbouring free cells), so every guarantee below holds across
plans.

**Guarantees** (each property-tested in ``tests/execution/test_executor.py`` against the
independent world of :mod:`warehouse_phys.execution.async_grid`):

- *No vertex conflict, no swap, whatever the delays:* any two robots' centres stay at
  least ``min_gap`` apart at every instant. Robots that hold no common cell are on
  disjoint edges of the grid of centres, at least one cell apart; two that hold one
  cell are a leader leaving it and a follower entering it (a robot enters a cell only
  while, or after, every robot planned to hold it before leaves it: the chain of
  type-2 edges; robots planned to hold it later wait for it), and following keeps
  their gap. A swap would bring two centres together; plans with swaps are refused.
- *No deadlock:* every edge goes from a move of a step to a move of the same step or a
  later one; a follower waits only for its leader's progress, never the other way.
  A *rotation* (robots each entering the cell the next one leaves, round a cycle) is
  the one closed chain: its robots would each need the next one's progress, so they
  move as one: each goes only as the whole rotation goes (never alone), from rest
  together, so they keep the same share of their moves and pass each other's corners
  ``sqrt(1/2)`` apart. :meth:`Executor.add_plan` therefore refuses a rotation whose
  robots' moves take different ticks, or any rotation when ``min_gap`` is above
  ``sqrt(1/2)`` (plan such fleets with
  :func:`~warehouse_phys.execution.windows.pibt_window`'s ``rotations=False``).
  Then the earliest unfinished moves are always free to go: every tick in which no
  robot is delayed, after the last release, advances some move, and a window
  completes within ``last release + sum of its moves' ticks`` once delays end.
- *Lock step is the special case:* with every move one tick, no delays and ``min_gap``
  at most its default (the corner follow's ``sqrt(1/2)``), the robots stand at the
  tick ``t0 + s`` where the plan given at ``t0`` puts them at step ``s``.

**Cost.** Per tick O(N) array operations (no loop over robots), plus one more O(N)
pass for each doubling of the longest hand-over chain that starts in the tick (none
without hand-overs); :meth:`Executor.add_plan` is O(N W log(N W)) for a window of W
steps. Memory: a few integers a robot, plus four of them per step of the window.

**Turning robots** (``headings=``, LoRR's model): a plan gives each robot's cell and
heading at every step; an *action* is a forward move along the heading (a move as
above) or a quarter turn in place, each of ``ticks_needed`` ticks. A turn holds the
robot's cell and depends only on the robot's own actions before it; :attr:`Executor.headings`
changes when a turn ends, :attr:`Executor.facing` is the heading the current action
ends facing.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame. Two parts of the model live beside it: the follow rule, whether a robot may
advance into the cell its leader is leaving (:mod:`~warehouse_phys.execution.following`),
and the checks that a plan can be executed (:mod:`~warehouse_phys.execution.plan_checks`);
the graph's guarantees rest on the three together.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from warehouse_phys.execution.following import DEFAULT_MIN_GAP, follow_permits
from warehouse_phys.execution.plan_checks import (
    NO_ROBOT,
    and_along,
    check_plan,
    check_turns,
    checked_cells,
    checked_delayed,
    checked_gap,
    checked_headings,
    checked_path,
    checked_ticks,
    rows_cols,
)
from warehouse_phys.execution.swept_squares import checked_size
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import neighbour_table

#: Release of a move that may start at once [ticks].
_AT_ONCE = np.iinfo(np.int64).min // 2


class TickReport(NamedTuple):
    """What one tick did, robot by robot (``(N,)`` bool arrays)."""

    #: The command: GO (True) or STOP.
    go: np.ndarray
    #: The cell index each robot heads for: its move's cell, its own cell with no move.
    heading: np.ndarray
    #: Went one tick along its move: GO and not delayed.
    advanced: np.ndarray
    #: Its move ended with this tick: the robot is at rest on the cell it entered (the
    #: physics twin snaps it there).
    ended: np.ndarray
    #: Had a move to make (in mid-move, or one released) and stood still, delayed.
    own_delay: np.ndarray
    #: Had a move to make, was not delayed and stood still: a robot ahead had not left
    #: the cell (knock-on delay).
    knock_on: np.ndarray
    #: Turning robots: the heading each robot's action ends facing (its heading with no
    #: action); ``None`` for four-direction robots.
    facing: np.ndarray | None = None


class TickCommand(NamedTuple):
    """What the executor commands for a tick before its delays are known (``(N,)`` arrays):
    :meth:`Executor.command`, given back to :meth:`Executor.step` once they are."""

    #: May advance this tick if not delayed (GO), before hand-overs.
    ready: np.ndarray
    #: Whom each robot follows together (itself if nobody): it goes only if that one advances.
    link: np.ndarray
    #: Has a move to make now (in mid-move, or one released).
    waiting: np.ndarray
    #: The cell each robot's current or next move enters (its own cell with none).
    target: np.ndarray


class Executor:
    """Executes lock-step plans on robots whose moves take ticks and who may be delayed.

    See the module for the model and its guarantees. Cells are given as ``(row, col)``
    pairs, and :meth:`plan_cells` returns them so; :attr:`left`, :attr:`entered`,
    :meth:`held` and :attr:`TickReport.heading` are cell indices (``row * cols + col``),
    as the fleet's arrays are.

    Args:
        grid: The floor.
        cells: ``(N, 2)`` each robot's cell, at rest; no two the same, none on a shelf.
        ticks_needed: ``(N,)`` the ticks each robot's move (or turn) takes (at least 1;
            all 1 is lock step), or one integer for every robot.
        min_gap: The closest two robots' centres may come [cells], in ``(0, 1]``: the
            physics twin asks for what its bodies need
            (:func:`~warehouse_phys.physics.tick_controller.required_min_gap`); 1 lets no robot
            round a corner behind another before the other's move ends.
        headings: ``(N,)`` turning robots' headings (0..3,
            :class:`~warehouse_phys.world.headings.Heading`); ``None`` (default) for
            four-direction robots. Turning robots' plans give a heading at every step.
        agent_size: ``None`` (default) for robots that are discs kept ``min_gap`` apart
            (our model); a side in ``(0, 1]`` cells for the League of Robot Runners'
            square robots (its instances' ``agentSize``): a robot then advances only where
            the start kit's swept squares never collide, whatever the tick's delays
            (:mod:`~warehouse_phys.execution.swept_squares`; ``min_gap`` is then unused),
            no robot goes together with its leader, so :meth:`command` is the tick's GO
            before its delays are drawn, and no plan may rotate robots.

    Raises:
        ValueError: naming the argument, if a cell is off the floor, on a shelf or shared,
            a robot's ``ticks_needed`` is below 1, ``min_gap`` is outside ``(0, 1]`` or
            ``agent_size`` outside ``(0, 1]``.
        TypeError: if ``ticks_needed`` is not integers or ``min_gap`` or ``agent_size``
            not a real number.
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
        self.grid = grid
        #: The closest two robots' centres may come [cells] (see the module).
        self.min_gap = checked_gap(min_gap)
        #: Square robots' side [cells] (the kit's swept squares), ``None`` for discs.
        self.agent_size = None if agent_size is None else checked_size(agent_size)
        here = checked_cells(grid, cells)
        n = len(here)
        #: Turning robots: the heading each faces (at the start of its current action),
        #: and the one its current action ends facing; ``None`` for four-direction robots.
        self.headings = None if headings is None else checked_headings(headings, n)
        self.facing = None if headings is None else self.headings.copy()
        self._needed = checked_ticks(ticks_needed, n)
        self._robots = np.arange(n)
        #: Ticks executed so far; the next tick is tick number ``tick``.
        self.tick = 0
        #: The cell each robot is on, or leaves in mid-move (cell indices).
        self.left = here
        #: The cell each robot enters in mid-move; its own cell at rest.
        self.entered = here.copy()
        #: Ticks done of each robot's current move (0 at rest).
        self.done = np.zeros(n, dtype=np.int64)
        self._next = np.zeros(n, dtype=np.int64)  # the move in progress or next
        self._count = np.zeros(n, dtype=np.int64)  # moves in each robot's sequence
        self._moves = _Moves.empty(n, 1)
        #: Cell -> the robot leaving it in mid-move, while a plan is added (else NO_ROBOT).
        self._leaver = np.full(grid.rows * grid.cols, NO_ROBOT, dtype=np.int64)
        self._table = neighbour_table(grid)

    @property
    def ticks_needed(self) -> np.ndarray:
        """``(N,)`` the ticks each robot's move takes (read-only)."""
        view = self._needed.view()
        view.flags.writeable = False
        return view

    def plan_cells(self) -> np.ndarray:
        """``(N, 2)`` where each robot's next plan starts: the cell its current move ends
        in, its own cell at rest. These cells are distinct: plan from them."""
        return rows_cols(self.entered, self.grid.cols)

    def plan_headings(self) -> np.ndarray | None:
        """Turning robots: ``(N,)`` the heading each robot's next plan starts with (the
        one its current action ends facing); ``None`` for four-direction robots."""
        return None if self.facing is None else self.facing.copy()

    def held(self) -> np.ndarray:
        """``(N, 2)`` the cells each robot holds now (cell indices): the cell it left and
        the cell it enters, the same cell twice at rest."""
        return np.stack([self.left, self.entered], axis=1)

    def window_done(self) -> bool:
        """Whether every robot has made every move of the plan given last."""
        return bool((self._next >= self._count).all())

    def drift(self) -> np.ndarray:
        """``(N,)`` how many ticks each robot is behind its plan now: the ticks since its
        current (or next) move should have started, less the ticks it has done of it;
        0 for a robot on time or done with its plan."""
        pending = self._next < self._count
        release = self._moves.release[self._robots, np.minimum(self._next, self._moves.width - 1)]
        behind = self.tick - release - self.done
        return np.where(pending & (release != _AT_ONCE), np.maximum(behind, 0), 0)

    def add_plan(self, path: np.ndarray) -> None:
        """Replace the moves not yet started with a new plan, from this tick on.

        Args:
            path: ``(N, S + 1, 2)`` each robot's ``(row, col)`` at steps ``0..S`` of a
                lock-step plan, step 0 being :meth:`plan_cells`: each step moves a
                robot to a neighbouring free cell or keeps it, never two robots to one
                cell, never two across one edge, no rotation of robots whose moves take
                different ticks (none if ``min_gap`` is above ``sqrt(1/2)``). Turning
                robots: ``(N, S + 1, 3)``, ``(row, col, heading)``, step 0 being
                :meth:`plan_cells` and :meth:`plan_headings`; each step a forward move
                along the heading, a quarter turn in place, or nothing.

        Raises:
            ValueError: naming ``path`` and the first robot and step that break this.
        """
        cells, faces = checked_path(self.grid, path, len(self._robots), self.facing is not None)
        rotating = check_plan(cells, self.entered, self._table, self._needed, self.grid,
                              self.min_gap, squares=self.agent_size is not None)  # fmt: skip
        if faces is not None:
            check_turns(cells, faces, self.facing, self.grid.cols)
        self._moves, self._count = _build_moves(
            cells, faces, self.facing, self.left, self.entered, self.done, self._needed,
            self.tick, self._leaver,
        )  # fmt: skip
        acted = cells[:, 1:] != cells[:, :-1]
        if faces is not None:
            acted |= faces[:, 1:] != faces[:, :-1]
        i, s = np.nonzero(rotating.T)  # robot, step - 1
        number = np.cumsum(acted, axis=1) - 1 + (self.done > 0)[:, None]
        self._moves.rotation[i, number[i, s]] = True
        self._next[:] = 0

    def command(self) -> TickCommand:
        """The next tick's command, before its delays are known: each robot's GO
        (``ready``), unless it follows another together (``link``), as :meth:`step` will
        run it. Give it back to :meth:`step` with the tick's delays; until then the
        executor must not change. With square robots nobody follows together: ``ready``
        is the tick's GO whatever the delays."""
        return TickCommand(*self._ready())

    def step(
        self, delayed: np.ndarray | None = None, command: TickCommand | None = None
    ) -> TickReport:
        """Run one tick: command every robot, advance those that go and are not delayed.

        Args:
            delayed: ``(N,)`` bool, the robots that cannot advance this tick; none by
                default.
            command: This tick's :meth:`command`, if it was asked for before the delays
                were known (the same as computed here).

        Returns:
            The tick's :class:`TickReport`.
        """
        n = len(self._robots)
        delayed = np.zeros(n, dtype=bool) if delayed is None else checked_delayed(delayed, n)
        ready, link, waiting, target = self._ready() if command is None else command
        advanced = ready & ~delayed
        follows = link != self._robots
        if follows.any():  # hand-overs: a follower goes only if its leader advances
            advanced = and_along(link, advanced)
        go = ready.copy()
        go[follows] &= advanced[link[follows]]
        starting = advanced & (self.done == 0)
        self.entered[starting] = target[starting]
        face = None
        if self.facing is not None:
            k = np.minimum(self._next, self._moves.width - 1)
            has = self._next < self._count
            face = np.where(has & (self.done == 0), self._moves.face[self._robots, k], self.facing)
            self.facing[starting] = face[starting]
        self.done += advanced
        ended = advanced & (self.done == self._needed)
        self.left[ended] = self.entered[ended]
        if self.headings is not None:
            self.headings[ended] = self.facing[ended]
        self.done[ended] = 0
        self._next += ended
        self.tick += 1
        own_delay, knock_on = waiting & delayed, waiting & ~delayed & ~go
        return TickReport(go, target, advanced, ended, own_delay, knock_on, face)

    def _ready(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Which robots may advance this tick if they are not delayed, whom each must
        follow (itself if nobody), which have a move to make now, and each move's cell."""
        robots, moves, done = self._robots, self._moves, self.done
        k = np.minimum(self._next, moves.width - 1)
        has = self._next < self._count
        target = np.where(has, moves.to[robots, k], self.entered)
        waiting = has & ((done > 0) | (moves.release[robots, k] <= self.tick))
        leader = moves.dep_robot[robots, k]
        depends = waiting & (leader != NO_ROBOT)
        j = np.where(depends, leader, robots)
        j_next, j_move = self._next[j], moves.dep_move[robots, k]
        on_it = np.flatnonzero(depends & (j_next == j_move))  # the leader is leaving the cell
        alone = np.zeros(len(robots), dtype=bool)
        together = np.zeros(len(robots), dtype=bool)
        if on_it.size:
            alone[on_it], together[on_it] = follow_permits(
                on_it, j[on_it], self.left, target, done, self._needed, self.grid.cols,
                self.min_gap, self.agent_size,
            )  # fmt: skip
            alone[on_it] &= ~moves.rotation[on_it, k[on_it]]  # a rotation goes as one
        ready = waiting & (~depends | (j_next > j_move) | alone | together)
        link = np.where(together & ~alone & ready, j, robots)
        return ready, link, waiting, target


class _Moves(NamedTuple):
    """Each robot's sequence of moves, ``(N, width)`` arrays (unused entries at the end)."""

    to: np.ndarray  # the cell the move enters
    release: np.ndarray  # the tick before which it may not start
    dep_robot: np.ndarray  # the robot whose move it waits for (NO_ROBOT: none)
    dep_move: np.ndarray  # that move's number in that robot's sequence
    rotation: np.ndarray  # the move is part of a rotation: it goes only as the whole one goes
    face: np.ndarray  # turning robots: the heading the action ends facing

    @property
    def width(self) -> int:
        return self.to.shape[1]

    @classmethod
    def empty(cls, n: int, width: int) -> _Moves:
        return cls(
            np.zeros((n, width), dtype=np.int64),
            np.full((n, width), _AT_ONCE, dtype=np.int64),
            np.full((n, width), NO_ROBOT, dtype=np.int64),
            np.zeros((n, width), dtype=np.int64),
            np.zeros((n, width), dtype=bool),
            np.zeros((n, width), dtype=np.int64),
        )


def _build_moves(
    path: np.ndarray,
    faces: np.ndarray | None,
    facing: np.ndarray | None,
    left: np.ndarray,
    entered: np.ndarray,
    done: np.ndarray,
    needed: np.ndarray,
    tick: int,
    leaver: np.ndarray,
) -> tuple[_Moves, np.ndarray]:
    """The dependency graph of a checked plan (``(N, S + 1)`` cell indices, and turning
    robots' headings ``faces``) joined to the actions in progress (turning robots: ending
    ``facing``): each robot's actions and their count. A turn depends on nothing but the
    robot's own actions before it."""
    n, steps = path.shape[0], path.shape[1] - 1
    robots = np.arange(n)
    in_mid = done > 0
    offset = in_mid.astype(np.int64)  # an action in progress stays as action 0
    moved = np.zeros((n, steps + 1), dtype=bool)
    moved[:, 1:] = path[:, 1:] != path[:, :-1]
    if faces is not None:
        moved[:, 1:] |= faces[:, 1:] != faces[:, :-1]
    number = np.cumsum(moved, axis=1) - 1 + offset[:, None]  # move number of each step
    moves = _Moves.empty(n, steps + 1)
    moves.to[in_mid, 0] = entered[in_mid]
    moves.release[in_mid, 0] = tick - done[in_mid]
    start = tick + np.where(in_mid, needed - done, 0)  # each robot's plan starts then
    i, s = np.nonzero(moved)
    k = number[i, s]
    moves.to[i, k] = path[i, s]
    moves.release[i, k] = start[i] + (s - 1) * needed[i]
    if faces is not None:
        moves.face[in_mid, 0] = facing[in_mid]
        moves.face[i, k] = faces[i, s]
    # The previous holder of each cell entered: the visits sorted by cell, then step.
    order = np.lexsort((np.tile(np.arange(steps + 1), n), path.ravel()))
    previous = np.full(path.size, -1, dtype=np.int64)
    same_cell = path.ravel()[order[1:]] == path.ravel()[order[:-1]]
    previous[order[1:][same_cell]] = order[:-1][same_cell]
    before = previous[i * (steps + 1) + s]
    j, s_before = np.divmod(before, steps + 1)
    other = (before >= 0) & (j != i)
    moves.dep_robot[i[other], k[other]] = j[other]
    moves.dep_move[i[other], k[other]] = number[j[other], s_before[other] + 1]
    # A cell's first planned holder waits for the robot leaving it in mid-move, if any.
    in_mid &= left != entered  # in mid-move (a turn leaves no cell)
    leaver[left[in_mid]] = robots[in_mid]
    behind = leaver[entered[in_mid]]  # a robot in mid-move into a cell another is leaving
    moves.dep_robot[in_mid, 0] = behind
    moves.dep_move[in_mid, 0] = 0
    first = before < 0
    waits_for = leaver[path[i[first], s[first]]]
    leaver[left[in_mid]] = NO_ROBOT
    has_leaver = waits_for != NO_ROBOT
    moves.dep_robot[i[first][has_leaver], k[first][has_leaver]] = waits_for[has_leaver]
    moves.dep_move[i[first][has_leaver], k[first][has_leaver]] = 0
    return moves, offset + moved.sum(axis=1)
