"""Asynchronous execution of a fleet's plans: a dependency graph that keeps them safe under delays.

A planner (:class:`~warehouse_phys.rules.planning.PIBT`) plans in lock step: every robot
makes one move, or waits, per *step*. Real robots do not keep step: a move takes
``ticks_needed`` ticks of the clock (one robot may be slower than another) and a robot
can be *delayed* for a tick (a person in the way, a wheel slipping), which stops it
where it is. :class:`Executor` runs lock-step plans on such robots without ever letting
two of them hold one cell: an Action Dependency Graph (Hoenig, Kiesel, Tinka, Durham
and Ayanian, "Persistent and robust execution of MAPF schedules in warehouses", RA-L
2019), kept as arrays.

**Ticks.** Between two ticks a robot is either *at rest* on a cell or *in mid-move*
between the cell it left and the cell it enters, some ticks of its move done; in
mid-move it holds both cells. Each tick the executor says GO or STOP to every robot;
a GO robot that is not delayed advances one tick of its move (starting it if it was at
rest); a move ends after ``ticks_needed`` ticks, and the robot is at rest on the cell
it entered. A robot in mid-move always gets GO: it holds both its cells already.

**The graph.** :meth:`Executor.add_plan` turns a plan, each robot's cells step by
step, into per-robot sequences of moves (a planned wait is no action; it only delays
the robot's next move, below) with one dependency each: a robot's move into cell ``c``
depends on the move by which ``c``'s previous planned holder leaves it (Hoenig's type-2
edge; the holders before that left before that one came, so one edge suffices), and
on the robot's own earlier moves (type-1: the sequence is done in order). A move may
start in a tick when its dependency has ended, or *ends in that same tick* (its robot
is in the move's last tick and advances): a robot then follows another on the tick the
other's move ends, so that, with moves of one tick, a line of robots moves together as
in lock step. Those hand-overs form chains (the leader of a follower may itself start
and end its move in the tick); the chain goes only if its head does, decided by
pointer doubling, and a closed chain (a *rotation*: robots each entering the cell the
next one leaves) goes in one tick when none of its robots is delayed.

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

**Guarantees** (each property-tested in ``tests/rules/test_executor.py`` against the
independent world of :mod:`warehouse_phys.rules.async_grid`):

- *No vertex conflict, no swap, whatever the delays:* a robot enters a cell only after
  every robot planned to hold it before has left it (the chain of type-2 edges), or
  as it leaves it in the same tick; robots planned to hold a cell later wait for it.
- *No deadlock:* every edge goes from a move of a step to a move of the same step or a
  later one; same-step edges are hand-overs, which form chains and, in a rotation,
  cycles. Chains go with their head. A rotation can be made only in one tick (in
  mid-move its robots would need twice as many cells as it has), so
  :meth:`Executor.add_plan` refuses a plan that rotates a robot whose moves take more
  than one tick (plan such fleets without rotations: ``PIBT(corner_follows=False)``).
  Then the earliest unfinished moves are always free to go: every tick in which no
  robot is delayed, after the last release, advances some move, and a window completes
  within ``last release + sum of its moves' ticks`` once delays end.
- *Lock step is the special case:* with every move one tick and no delays, the robots
  stand at the tick ``t0 + s`` where the plan given at ``t0`` puts them at step ``s``.

**Cost.** Per tick O(N) array operations (no loop over robots), plus one more O(N)
pass for each doubling of the longest hand-over chain that starts in the tick (none
without hand-overs); :meth:`Executor.add_plan` is O(N W log(N W)) for a window of W
steps. Memory: a few integers a robot, plus four of them per step of the window.

**Turning robots** (``moves="rotate"``) would need moves over ``(cell, heading)``: a
turn holds one cell and depends only on the robot's own sequence, a forward move as
here, and ``ticks_needed`` per action kind. This module takes four-direction robots.

Like :mod:`warehouse_phys.rules.grid`, this module imports neither gymnasium, pymunk nor
pygame. Its length is one algorithm, the dependency graph, with the checks that a plan
can be executed: split, the graph's guarantees would rest on two modules.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from warehouse_phys.rules.grid import WarehouseGrid
from warehouse_phys.rules.traffic import neighbour_table, robot_cell_indices

if TYPE_CHECKING:
    from warehouse_phys.rules.planning import PIBT

#: "No robot" in the dependency arrays.
NO_ROBOT = -1
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


class Executor:
    """Executes lock-step plans on robots whose moves take ticks and who may be delayed.

    See the module for the model and its guarantees. Cells are given as ``(row, col)``
    pairs, and :meth:`plan_cells` returns them so; :attr:`left`, :attr:`entered`,
    :meth:`held` and :attr:`TickReport.heading` are cell indices (``row * cols + col``),
    as the fleet's arrays are.

    Args:
        grid: The floor.
        cells: ``(N, 2)`` each robot's cell, at rest; no two the same, none on a shelf.
        ticks_needed: ``(N,)`` the ticks each robot's move takes (at least 1; all 1 is
            lock step), or one integer for every robot.

    Raises:
        ValueError: naming the argument, if a cell is off the floor, on a shelf or shared,
            or a robot's ``ticks_needed`` is below 1.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        cells: np.ndarray,
        ticks_needed: np.ndarray | int = 1,
    ) -> None:
        self.grid = grid
        here = _checked_cells(grid, cells)
        n = len(here)
        self._needed = _checked_ticks(ticks_needed, n)
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
        return _rows_cols(self.entered, self.grid.cols)

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
                cell, never two across one edge, never a robot whose moves take more
                than one tick round a rotation.

        Raises:
            ValueError: naming ``path`` and the first robot and step that break this.
        """
        cells = _checked_path(self.grid, path, len(self._robots))
        _check_plan(cells, self.entered, self._table, self._needed, self.grid)
        self._moves, self._count = _build_moves(
            cells, self.left, self.entered, self.done, self._needed, self.tick, self._leaver
        )
        self._next[:] = 0

    def step(self, delayed: np.ndarray | None = None) -> TickReport:
        """Run one tick: command every robot, advance those that go and are not delayed.

        Args:
            delayed: ``(N,)`` bool, the robots that cannot advance this tick; none by
                default.

        Returns:
            The tick's :class:`TickReport`.
        """
        n = len(self._robots)
        delayed = np.zeros(n, dtype=bool) if delayed is None else _checked_delayed(delayed, n)
        ready, link, waiting, target = self._ready(delayed)
        advanced = ready & ~delayed
        follows = link != self._robots
        if follows.any():  # hand-overs: a follower goes only if its leader advances
            advanced = _and_along(link, advanced)
        go = ready.copy()
        go[follows] &= advanced[link[follows]]
        starting = advanced & (self.done == 0)
        self.entered[starting] = target[starting]
        self.done += advanced
        ended = advanced & (self.done == self._needed)
        self.left[ended] = self.entered[ended]
        self.done[ended] = 0
        self._next += ended
        self.tick += 1
        own_delay, knock_on = waiting & delayed, waiting & ~delayed & ~go
        return TickReport(go, target, advanced, ended, own_delay, knock_on)

    def _ready(self, delayed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Which robots may advance this tick if they are not delayed, whom each must
        follow (itself if nobody), which have a move to make now, and each move's cell."""
        robots, moves, done = self._robots, self._moves, self.done
        k = np.minimum(self._next, moves.width - 1)
        has = self._next < self._count
        target = np.where(has, moves.to[robots, k], self.entered)
        in_mid = done > 0
        waiting = has & (in_mid | (moves.release[robots, k] <= self.tick))
        leader = moves.dep_robot[robots, k]
        depends = waiting & ~in_mid & (leader != NO_ROBOT)
        j = np.where(depends, leader, robots)
        j_next, j_move = self._next[j], moves.dep_move[robots, k]
        on_it = depends & (j_next == j_move)
        ends_now = on_it & (done[j] + 1 == self._needed[j]) & ~delayed[j] & (done[j] > 0)
        hand_over = on_it & (done[j] == 0) & (self._needed[j] == 1)
        clear = ~depends | (j_next > j_move) | ends_now | hand_over
        ready = waiting & clear
        link = np.where(hand_over & ready, j, robots)
        return ready, link, waiting, target


class _Moves(NamedTuple):
    """Each robot's sequence of moves, ``(N, width)`` arrays (unused entries at the end)."""

    to: np.ndarray  # the cell the move enters
    release: np.ndarray  # the tick before which it may not start
    dep_robot: np.ndarray  # the robot whose move it waits for (NO_ROBOT: none)
    dep_move: np.ndarray  # that move's number in that robot's sequence

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
        )


def _build_moves(
    path: np.ndarray,
    left: np.ndarray,
    entered: np.ndarray,
    done: np.ndarray,
    needed: np.ndarray,
    tick: int,
    leaver: np.ndarray,
) -> tuple[_Moves, np.ndarray]:
    """The dependency graph of a checked plan (``(N, S + 1)`` cell indices) joined to the
    moves in progress: each robot's moves and their count."""
    n, steps = path.shape[0], path.shape[1] - 1
    robots = np.arange(n)
    in_mid = done > 0
    offset = in_mid.astype(np.int64)  # a move in progress stays as move 0
    moved = np.zeros((n, steps + 1), dtype=bool)
    moved[:, 1:] = path[:, 1:] != path[:, :-1]
    number = np.cumsum(moved, axis=1) - 1 + offset[:, None]  # move number of each step
    moves = _Moves.empty(n, steps + 1)
    moves.to[in_mid, 0] = entered[in_mid]
    moves.release[in_mid, 0] = tick - done[in_mid]
    start = tick + np.where(in_mid, needed - done, 0)  # each robot's plan starts then
    i, s = np.nonzero(moved)
    k = number[i, s]
    moves.to[i, k] = path[i, s]
    moves.release[i, k] = start[i] + (s - 1) * needed[i]
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
    leaver[left[in_mid]] = robots[in_mid]
    first = before < 0
    waits_for = leaver[path[i[first], s[first]]]
    leaver[left[in_mid]] = NO_ROBOT
    has_leaver = waits_for != NO_ROBOT
    moves.dep_robot[i[first][has_leaver], k[first][has_leaver]] = waits_for[has_leaver]
    moves.dep_move[i[first][has_leaver], k[first][has_leaver]] = 0
    return moves, offset + moved.sum(axis=1)


def _and_along(link: np.ndarray, value: np.ndarray) -> np.ndarray:
    """``value[i]`` and-ed with the values down ``i``'s chain of links (round its cycle),
    by pointer doubling: ``link[i] == i`` ends a chain."""
    value = value.copy()
    for _ in range(max(1, len(link)).bit_length()):
        further = link[link]
        value &= value[link]
        if (further == link).all():
            return value
        link = further
    value &= value[link]  # a cycle: 2**bit_length(n) >= n links, round it and beyond
    return value


def _check_plan(
    path: np.ndarray,
    start: np.ndarray,
    table: np.ndarray,
    needed: np.ndarray,
    grid: WarehouseGrid,
) -> None:
    """Refuse a plan (``(N, S + 1)`` cell indices) that does not start from ``start``,
    makes a move that is not one, puts two robots in a cell or across an edge, or rotates
    a robot whose moves take more than one tick."""
    cols = grid.cols
    wrong = np.flatnonzero(path[:, 0] != start)
    if wrong.size:
        i = int(wrong[0])
        raise ValueError(
            f"path must start from plan_cells(): robot {i} starts at "
            f"{_cell(path[i, 0], cols)}, not {_cell(start[i], cols)}"
        )
    n, steps = path.shape[0], path.shape[1] - 1
    if not steps or not n:
        return
    step_ok = (table[path[:, :-1]] == path[:, 1:, None]).any(axis=2)
    if not step_ok.all():
        i, s = (int(v[0]) for v in np.nonzero(~step_ok))
        raise ValueError(
            f"path moves robot {i} from {_cell(path[i, s], cols)} to "
            f"{_cell(path[i, s + 1], cols)} at step {s + 1}: not a move to a free neighbour"
        )
    by_step = np.sort(path, axis=0)
    shared = np.nonzero(by_step[1:] == by_step[:-1])
    if shared[0].size:
        s = int(shared[1][0])
        cell = by_step[shared[0][0], s]
        both = np.flatnonzero(path[:, s] == cell)[:2].tolist()
        raise ValueError(f"path puts robots {both} on {_cell(cell, cols)} at step {s}")
    _check_follows(path, needed, cols)


def _check_follows(path: np.ndarray, needed: np.ndarray, cols: int) -> None:
    """Refuse swaps, and rotations of robots whose moves take more than one tick."""
    n, steps = path.shape[0], path.shape[1] - 1
    # Who stands on each cell at each step: (step, cell) keys sorted, looked up.
    keys = (np.arange(steps + 1)[None, :] * (path.max() + 1) + path).T.ravel()
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    s_all = np.repeat(np.arange(steps), n)
    before, after = path[:, :-1].T.ravel(), path[:, 1:].T.ravel()
    enter = s_all * (path.max() + 1) + after  # the entered cell, one step earlier
    spot = np.minimum(np.searchsorted(sorted_keys, enter), len(keys) - 1)
    found = (sorted_keys[spot] == enter) & (before != after)
    occupant = np.where(found, order[spot] % n, -1)  # robot there before the step
    node = np.arange(n * steps)
    follows = found & (occupant != node % n)
    leader = np.where(follows, s_all * n + occupant, node)
    swap = follows & (after[leader] == before)
    if swap.any():
        x = int(np.flatnonzero(swap)[0])
        pair = sorted((x % n, int(occupant[x])))
        raise ValueError(f"path swaps robots {pair} at step {x // n + 1}")
    rotating = _and_along(leader, follows)  # every robot down its chain follows: a cycle
    slow = rotating & (needed[node % n] > 1)
    if slow.any():
        x = int(np.flatnonzero(slow)[0])
        raise ValueError(
            f"path rotates robot {x % n} (ticks_needed {int(needed[x % n])}) round a cycle "
            f"at step {x // n + 1}: robots in mid-move hold two cells, so only robots whose "
            "moves take one tick can rotate; plan without rotations (PIBT(corner_follows=False))"
        )


def pibt_window(
    planner: PIBT, cells: np.ndarray, goals: np.ndarray, steps: int, **plan_options: object
) -> np.ndarray:
    """A lock-step plan of ``steps`` steps from ``cells`` (``(N, 2)``): ``planner`` asked
    ``steps`` times, each time on the cells its last plan leads to, towards ``goals``.

    Returns:
        ``(N, steps + 1, 2)`` int64, each robot's ``(row, col)`` at each step, for
        :meth:`Executor.add_plan`.
    """
    grid = planner.grid
    table = neighbour_table(grid)
    here = _checked_cells(grid, cells)
    path = np.empty((len(here), steps + 1), dtype=np.int64)
    path[:, 0] = here
    for s in range(steps):
        actions = planner.plan(_rows_cols(here, grid.cols), goals, **plan_options)
        here = table[here, actions]
        path[:, s + 1] = here
    return _rows_cols(path, grid.cols)


def _checked_cells(grid: WarehouseGrid, cells: np.ndarray) -> np.ndarray:
    """Distinct free cells as cell indices, or a one-line ``ValueError`` naming ``cells``."""
    here = robot_cell_indices(grid, cells, prefix="cells: ")
    shelf = ~grid.free_mask.reshape(-1)[here]
    if shelf.any():
        i = int(np.flatnonzero(shelf)[0])
        raise ValueError(f"cells: robot {i}'s cell {divmod(int(here[i]), grid.cols)} is a shelf")
    return here


def _checked_ticks(ticks_needed: np.ndarray | int, n: int) -> np.ndarray:
    """``(N,)`` int64 ticks of at least 1, or a one-line error naming ``ticks_needed``."""
    ticks = np.asarray(ticks_needed)
    if ticks.dtype.kind not in "iu":
        raise TypeError(f"ticks_needed must be integers, got {ticks.dtype}")
    if ticks.ndim == 0:
        ticks = np.full(n, int(ticks), dtype=np.int64)
    if ticks.shape != (n,):
        raise ValueError(
            f"ticks_needed must be one integer or one per robot ({n}), got {ticks.shape}"
        )
    if (ticks < 1).any():
        i = int(np.flatnonzero(ticks < 1)[0])
        raise ValueError(f"ticks_needed must be at least 1, got {int(ticks[i])} for robot {i}")
    return ticks.astype(np.int64)


def _checked_path(grid: WarehouseGrid, path: np.ndarray, n: int) -> np.ndarray:
    """``(N, S + 1)`` cell indices of a plan's ``(row, col)`` cells on the floor."""
    path = np.asarray(path)
    if path.ndim != 3 or path.shape[0] != n or path.shape[1] < 1 or path.shape[2] != 2:
        raise ValueError(f"path must be (N={n}, steps + 1, 2) cells, got shape {path.shape}")
    if path.dtype.kind not in "iu":
        raise ValueError(f"path must hold integer cells, got {path.dtype}")
    rows, cols = path[..., 0].astype(np.int64), path[..., 1].astype(np.int64)
    off = (rows < 0) | (rows >= grid.rows) | (cols < 0) | (cols >= grid.cols)
    if off.any():
        i, s = (int(v[0]) for v in np.nonzero(off))
        raise ValueError(f"path puts robot {i} off the floor at step {s}")
    return rows * grid.cols + cols


def _checked_delayed(delayed: np.ndarray, n: int) -> np.ndarray:
    delayed = np.asarray(delayed)
    if delayed.shape != (n,) or delayed.dtype != bool:
        raise ValueError(f"delayed must be ({n},) bool, got {delayed.dtype} {delayed.shape}")
    return delayed


def _rows_cols(cells: np.ndarray, cols: int) -> np.ndarray:
    return np.stack(np.divmod(cells, cols), axis=-1)


def _cell(index: int, cols: int) -> tuple[int, int]:
    return divmod(int(index), cols)
