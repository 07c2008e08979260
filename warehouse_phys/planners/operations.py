"""Multi-action operations for turning robots: PIBT over short action sequences (EPIBT).

One-step PIBT serves turning robots badly: a robot whose best cell is beside it turns
this step and can claim the cell only on the next, by when the plan that made the turn
worth it has changed. :class:`OperationPIBT` plans each step over *operations*, every
sequence of ``depth`` turning actions (:func:`operation_table`: 3 actions, 50 of the 64
once a quarter turn straight back is left out), after Yukhnevich and Andreychuk's EPIBT
(Enhancing PIBT via multi-action operations, 2025):

- Each robot holds an operation at every moment of the planning, and every cell at each
  of the operations' depths (and every move between two cells) is reserved by at most
  one robot. A robot begins a step holding the rest of its last operation followed by a
  wait (all waits on the first step, or when some robot did not do what was planned).
- Robots plan in decreasing priority
  (:func:`~warehouse_phys.planners.pibt.priorities.grow_priorities`, PIBT's own). A
  robot tries its operations best first (:meth:`OperationPIBT.plan`): one that meets no
  other robot's reservations is taken; one that meets exactly one robot of lower
  priority than the robot that began the chain takes that robot's place, and the robot
  put out plans again (priority inheritance); if it finds nothing, the robot that put it
  out gives its place back and tries its next operation. A robot is placed at most
  ``revisits`` times a step, and one chain puts robots out at most ``max_kicks`` times;
  a robot whose turn comes unplaced plans in it.
- Each robot then takes its operation's first action.

An operation is valued by where it leaves the robot: the step it reaches the goal, if it
does, else ``depth`` plus the fewest steps from its last cell and heading to a
neighbouring cell (quarter turns to face it and the move) plus that cell's value, a
distance to the goal or, guided, a value along the robot's guide path; among equals the
operation whose last cell is nearest the goal comes first (the value above leaves out the
turns a robot must make further on), then the one that waits least before its last
action, then the one with fewest actions (a robot on its goal waits), then a seeded draw.

What it does not promise: progress. A robot may put out only one robot at a time, and
a robot put out while it faces a wall cannot leave at once; in crowds of turning
robots every operation that brings the robots at the top nearer their goals can meet
two or more others, and the robots wait more and more (2024 WAREHOUSE's rows below its
pick-up pockets; with smaller ``revisits`` and ``max_kicks`` the fleet locked up: the
documentation's LoRR page, ``docs/lorr.md``, "Planning over operations"); nor is
there a swap operation, so two robots facing each other at a dead end's mouth stay there
and the robots behind them pile up (the main rounds' random floors:
:class:`~warehouse_phys.planners.guidance.GuidedPIBT` then hands over to one-step PIBT,
:mod:`warehouse_phys.planners.pibt.stalls`). Nor does it
plan beyond its operations' steps by itself: a
:class:`~warehouse_phys.planners.repair.WindowRepair` given to :meth:`OperationPIBT.plan`
improves the plan over them (LNS).

What it promises: every plan is granted by the traffic rule (the reservations forbid two
robots in one cell and swaps at every depth, and the step's actions pass
:func:`~warehouse_phys.world.headings.turning_moves` before they are returned); the same
plans for the same seed and inputs. Without corner follows a robot enters a cell only
when nobody held it the step before (no following at all). Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.operation_kernels import (
    _operation_paths,
    _operation_pibt,
    _operation_values,
    _rank_operations,
    _reserve_all,
)
from warehouse_phys.planners.pibt.priorities import grow_priorities
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import (
    HEADING_MOVES,
    MOVE_HEADINGS,
    TurnAction,
    turning_moves,
)
from warehouse_phys.world.traffic import neighbour_table

#: Actions in an operation by default.
DEPTH = 3
#: Times a robot may be placed in one step by default (it may be put out after the first).
REVISITS = 4
#: Times one robot's chain may put robots out, by default (bounds a step's work).
MAX_KICKS = 512


def operation_table(depth: int = DEPTH) -> np.ndarray:
    """Every sequence of ``depth`` turning actions without a quarter turn straight back
    (clockwise then counter-clockwise, or the reverse: two waits do the same), all waits
    first: ``(K, depth)`` int64 of :class:`~warehouse_phys.world.headings.TurnAction`.

    Raises:
        ValueError: if ``depth`` is not 1..4.
    """
    if not 1 <= depth <= 4:
        raise ValueError(f"depth must be 1..4, got {depth!r}")
    turns = {int(TurnAction.CLOCKWISE), int(TurnAction.COUNTERCLOCKWISE)}
    kept = [
        ops
        for ops in itertools.product(range(4), repeat=depth)
        if not any({a, b} == turns for a, b in itertools.pairwise(ops))
    ]
    waits = (int(TurnAction.WAIT),) * depth
    kept.remove(waits)
    return np.array([waits, *kept], dtype=np.int64)


def local_offsets(depth: int = DEPTH) -> np.ndarray:
    """The ``(row, col)`` offsets from a robot of the cells an operation of ``depth``
    actions can value: the cells within ``depth + 1`` moves (``(M, 2)`` int64)."""
    reach = depth + 1
    return np.array(
        [(r, c) for r in range(-reach, reach + 1) for c in range(-reach, reach + 1)
         if abs(r) + abs(c) <= reach],
        dtype=np.int64,
    )  # fmt: skip


@dataclass
class _Plan:
    """A step's robots (cell indices, goals, headings, who moves and who is there), their
    operations (cells and headings at each depth, ranks and values) and reservations."""

    here: np.ndarray
    goal: np.ndarray
    heading: np.ndarray
    movable: np.ndarray
    present: np.ndarray
    cells: np.ndarray
    heads: np.ndarray
    ranked: np.ndarray
    values: np.ndarray
    at: np.ndarray
    leaving: np.ndarray
    standing: np.ndarray


class OperationPIBT:
    """PIBT over multi-action operations for turning robots (the module's docstring),
    stateful across the steps of an episode (the robots' priorities).

    ``plan(cells, goals, movable, present, headings=...)`` returns every robot's
    :class:`~warehouse_phys.world.headings.TurnAction` for the next joint step, as
    :meth:`PIBT.plan <warehouse_phys.planners.pibt.PIBT.plan>` does for turning robots:
    robots not ``movable`` (parked) hold their cells, robots not ``present`` are ignored
    and wait, and every plan is granted by the traffic rule.

    Args:
        grid: The floor.
        distances: The floor's distance maps (a fleet's ``env.distances``); new by default.
        corner_follows: Whether traffic grants corner follows (the fleet's
            ``corner_follows``); without them no robot follows another.
        seed: Seeds the priorities' tie-breakers and the operations' ties.
        depth: Actions in an operation (1..4).
        revisits: Times a robot may be placed in one step (at least 1).
        max_kicks: Times the chain of one robot planning in its turn may put robots out
            (at least 0; 0: no priority inheritance).

    Raises:
        ValueError: for a ``depth``, ``revisits`` or ``max_kicks`` out of range.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        *,
        distances: DistanceMaps | None = None,
        corner_follows: bool = True,
        seed: int = 0,
        depth: int = DEPTH,
        revisits: int = REVISITS,
        max_kicks: int = MAX_KICKS,
    ) -> None:
        if revisits < 1 or max_kicks < 0:
            raise ValueError(f"revisits must be >= 1 and max_kicks >= 0, got {revisits!r} "
                             f"and {max_kicks!r}")  # fmt: skip
        self.grid = grid
        self.distances = DistanceMaps(grid) if distances is None else distances
        self.corner_follows = bool(corner_follows)
        self.depth = depth
        self.revisits = int(revisits)
        self.max_kicks = int(max_kicks)
        self.ops = operation_table(depth)
        self._index = {tuple(op): k for k, op in enumerate(self.ops.tolist())}
        self.rng = np.random.default_rng(seed)
        self._table = neighbour_table(grid)
        self._offsets = local_offsets(depth)
        reach = depth + 1
        self._slot_of = np.full((2 * reach + 1) ** 2, -1, dtype=np.int64)
        index = (self._offsets[:, 0] + reach) * (2 * reach + 1) + self._offsets[:, 1] + reach
        self._slot_of[index] = np.arange(len(self._offsets))
        self._priority: np.ndarray | None = None
        self._goals: np.ndarray | None = None
        #: Each operation less its first action, followed by a wait.
        self._shifted = np.array([self._index[(*op[1:], int(TurnAction.WAIT))]
                                  for op in self.ops.tolist()])  # fmt: skip
        #: Robots whose planned action the traffic rule refused in the last plan (they
        #: waited instead): none while the reservations keep robots apart.
        self.refused = 0
        #: What the last step planned: the operations left, where each robot was to be
        #: and face, which robots could move and were present, and whether any was refused.
        self._carry: tuple | None = None

    def local_cells(self, here: np.ndarray) -> np.ndarray:
        """The cells about each robot whose values :meth:`plan` may use: ``(N, M)`` cell
        indices in :func:`local_offsets` order, -1 off the floor or on a shelf."""
        rows, cols = self.grid.rows, self.grid.cols
        row = here[:, None] // cols + self._offsets[None, :, 0]
        col = here[:, None] % cols + self._offsets[None, :, 1]
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        cell = np.where(inside, row * cols + col, 0)
        free = np.asarray(self.grid.free_mask, dtype=bool).reshape(-1)[cell] & inside
        return np.where(free, cell, -1)

    def plan(
        self,
        cells: np.ndarray,
        goals: np.ndarray,
        movable: np.ndarray | None = None,
        present: np.ndarray | None = None,
        *,
        headings: np.ndarray,
        cell_values: np.ndarray | None = None,
        repair: WindowRepair | None = None,
    ) -> np.ndarray:
        """The next joint action: ``(N,)`` int64 turning actions from each robot's
        ``(row, col)`` ``cells``, ``goals`` (``(N, 2)``) and ``headings`` (``(N,)``,
        0..3); ``movable`` and ``present`` default to all.

        ``cell_values`` (``(N, M)`` float, optional) values the cells of
        :meth:`local_cells` for each robot, lower better (a guide: see
        :mod:`warehouse_phys.planners.guidance`), ``NaN`` where the distance to the goal
        is wanted. ``repair`` (optional) improves the plan of operations before its first
        actions are taken (:mod:`warehouse_phys.planners.repair`).

        Raises:
            ValueError: if the number of robots changes between calls, or the headings
                are not one of 0..3 a robot.
        """
        plan = self._prepare(cells, goals, movable, present, headings, cell_values, grow=True)
        here, heading, movable, present = plan.here, plan.heading, plan.movable, plan.present
        moving = np.flatnonzero(movable)
        chosen = self._carried(here, heading, movable, present)
        _reserve_all(np.flatnonzero(present), chosen, here, plan.cells, plan.heads,
                     HEADING_MOVES, plan.at, plan.leaving)  # fmt: skip
        order = moving[np.argsort(-self._priority[moving], kind="stable")]
        _operation_pibt(order, self._priority, ~movable, here, plan.ranked, plan.cells,
                        plan.heads, HEADING_MOVES, plan.at, plan.leaving, plan.standing, chosen,
                        self.revisits, self.max_kicks, self.corner_follows)  # fmt: skip
        return self._finish(plan, chosen, repair, None)

    def improve(
        self,
        cells: np.ndarray,
        goals: np.ndarray,
        movable: np.ndarray | None = None,
        present: np.ndarray | None = None,
        *,
        headings: np.ndarray,
        actions: np.ndarray,
        repair: WindowRepair,
        cell_values: np.ndarray | None = None,
    ) -> np.ndarray:
        """A one-step plan's turning ``actions`` (every one granted by the traffic rule, as
        PIBT's are) improved by ``repair``: each robot begins holding its action followed
        by waits, and the repair plans neighbourhoods again over the window
        (:mod:`warehouse_phys.planners.repair`). The arguments are :meth:`plan`'s; the
        priorities are left as they are. Returns the improved actions, or ``actions`` as
        given where the traffic rule would refuse any of the repaired ones."""
        plan = self._prepare(cells, goals, movable, present, headings, cell_values)
        actions = np.asarray(actions, dtype=np.int64)
        chosen = np.zeros(len(actions), dtype=np.int64)
        waits = (int(TurnAction.WAIT),) * (self.depth - 1)
        first = np.array([self._index[(a, *waits)] for a in range(4)], dtype=np.int64)
        chosen[plan.movable] = first[actions[plan.movable]]
        _reserve_all(np.flatnonzero(plan.present), chosen, plan.here, plan.cells, plan.heads,
                     HEADING_MOVES, plan.at, plan.leaving)  # fmt: skip
        repair.extend(np.flatnonzero(plan.movable), actions, self.ops[:, 0], plan.here,
                      plan.ranked, plan.cells, plan.heads, HEADING_MOVES, plan.at, plan.leaving,
                      plan.standing, chosen, self.corner_follows)  # fmt: skip
        return self._finish(plan, chosen, repair, actions)

    def _prepare(
        self,
        cells: np.ndarray,
        goals: np.ndarray,
        movable: np.ndarray | None,
        present: np.ndarray | None,
        headings: np.ndarray,
        cell_values: np.ndarray | None,
        grow: bool = False,
    ) -> _Plan:
        """A step's operations: where each takes its robot, their ranks, and empty
        reservations (:class:`_Plan`); with ``grow``, the priorities grow first."""
        cols = self.grid.cols
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        goals = np.asarray(goals, dtype=np.int64).reshape(-1, 2)
        n = len(cells)
        here = cells[:, 0] * cols + cells[:, 1]
        goal = goals[:, 0] * cols + goals[:, 1]
        heading = np.asarray(-1 if headings is None else headings, dtype=np.int64)
        if heading.shape != (n,) or ((heading < 0) | (heading > 3)).any():
            raise ValueError(f"turning robots need one heading 0..3 each ({n}), got {headings!r}")
        present = np.ones(n, dtype=bool) if present is None else np.asarray(present, bool)
        movable = present.copy() if movable is None else np.asarray(movable, bool) & present
        if grow:
            self._priority, self._goals = grow_priorities(self._priority, self._goals, here,
                                                          goal, self.rng)  # fmt: skip
        moving = np.flatnonzero(movable)
        k, depth = self.ops.shape
        op_cells = np.repeat(here, k * depth).reshape(n, k, depth)
        op_heads = np.repeat(heading, k * depth).reshape(n, k, depth)
        valid = np.zeros((n, k), dtype=bool)
        valid[:, 0] = True
        _operation_paths(here, heading, moving, self._table, HEADING_MOVES, self.ops, op_cells,
                         op_heads, valid)  # fmt: skip
        ranked, values = self._ranked(here, goal, moving, op_cells, op_heads, valid, cell_values,
                                      draw=grow)  # fmt: skip
        # Who holds each cell at each depth, who leaves each cell by each move at each
        # depth, who stands on each cell now (-1: nobody).
        at = np.full((self.grid.rows * cols, depth), -1, dtype=np.int64)
        leaving = np.full((self.grid.rows * cols * 4, depth), -1, dtype=np.int64)
        standing = np.full(self.grid.rows * cols, -1, dtype=np.int64)
        robots = np.flatnonzero(present)
        standing[here[robots]] = robots
        return _Plan(here, goal, heading, movable, present, op_cells, op_heads, ranked, values,
                     at, leaving, standing)  # fmt: skip

    def _finish(
        self, plan: _Plan, chosen: np.ndarray, repair: WindowRepair | None,
        fallback: np.ndarray | None,
    ) -> np.ndarray:  # fmt: skip
        """The plan's first actions, after ``repair`` if any, through the traffic rule;
        ``fallback`` (given) is returned instead where the rule refuses a repaired action."""
        if repair is not None:
            repair.improve(plan.movable, plan.here, plan.ranked, plan.values, plan.cells,
                           plan.heads, HEADING_MOVES, plan.at, plan.leaving, plan.standing,
                           chosen, self.corner_follows)  # fmt: skip
        here, heading, movable, present = plan.here, plan.heading, plan.movable, plan.present
        actions = np.where(movable, self.ops[chosen, 0], TurnAction.WAIT)
        grants = turning_moves(self.grid, here, heading, actions, ~movable & present,
                               corner_follows=self.corner_follows)  # fmt: skip
        if fallback is not None and grants.refused.any():
            if repair is not None:
                repair.stats.fell_back = True
            self._carry = None
            return fallback.copy()
        actions[grants.refused] = TurnAction.WAIT
        self.refused = int(grants.refused.sum())
        done = np.arange(len(here))
        self._carry = (self._shifted[chosen], plan.cells[done, chosen, 0],
                       plan.heads[done, chosen, 0], movable.copy(), present.copy(),
                       grants.refused.any())  # fmt: skip
        return actions

    def _carried(
        self, here: np.ndarray, heading: np.ndarray, movable: np.ndarray, present: np.ndarray
    ) -> np.ndarray:
        """Each robot's operation to begin the step with: the rest of last step's, followed
        by a wait, when every robot did what it was planned to and no robot came, went or
        parked; else all waits. Either way no two reserve one cell."""
        if self._carry is None:
            return np.zeros(len(here), dtype=np.int64)
        ops, cells, heads, movable_before, present_before, refused = self._carry
        same = (
            not refused
            and len(ops) == len(here)
            and np.array_equal(movable, movable_before)
            and np.array_equal(present, present_before)
            and np.array_equal(cells[present], here[present])
            and np.array_equal(heads[present], heading[present])
        )
        return ops.copy() if same else np.zeros(len(here), dtype=np.int64)

    def _ranked(
        self,
        here: np.ndarray,
        goal: np.ndarray,
        moving: np.ndarray,
        op_cells: np.ndarray,
        op_heads: np.ndarray,
        valid: np.ndarray,
        cell_values: np.ndarray | None,
        draw: bool = True,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Each robot's operations best first (``(N, K)``, -1 after its last valid one):
        by value, then a seeded draw (without ``draw``: the operations' order); and every
        operation's value (``(N, K)``)."""
        n, k = valid.shape
        local_cells = self.local_cells(here[moving])
        local = np.full((n, len(self._offsets)), np.inf)
        values = np.full(local_cells.shape, np.nan)
        if cell_values is not None:
            values = np.asarray(cell_values, dtype=np.float64)[moving]
        wanted = np.isnan(values) & (local_cells >= 0)  # the distance where no value is given
        targets = np.broadcast_to(goal[moving, None], local_cells.shape)
        values[wanted] = self.distances.lookup(local_cells[wanted], targets[wanted])
        local[moving] = np.where(np.isnan(values), np.inf, values)
        op_values = np.full((n, k), np.inf)
        op_values[:, 0] = 0.0
        _operation_values(here, goal, moving, self.grid.cols, self._table, MOVE_HEADINGS,
                          self.ops, op_cells, op_heads, valid, self._slot_of, self.depth + 1,
                          local, op_values)  # fmt: skip
        if not draw:
            ranked = np.full((n, k), -1, dtype=np.int64)
            ranked[:, 0] = 0  # robots that do not move wait
            _rank_operations(op_values, valid, moving, ranked)
            return ranked, op_values
        order = np.lexsort((self.rng.random((n, k)), op_values), axis=1)
        ranked = np.where(np.take_along_axis(valid, order, axis=1), order, -1)
        # Valid operations first, in order (an invalid one sorts as inf, with the unreachable).
        ranked = np.take_along_axis(ranked, np.argsort(ranked < 0, axis=1, kind="stable"), 1)
        return ranked, op_values
