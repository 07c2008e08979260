"""Turning robots under PIBT: candidates valued in turns, and the cells the robots turn
towards.

``PIBT(moves="rotate")`` (:class:`~warehouse_phys.planners.pibt.PIBT`) plans turning
robots (:mod:`warehouse_phys.world.headings`) over cells with its own recursion; this
module holds what differs. :func:`count_turns` values a robot's candidates by the quarter
turns to face them, the move and their distance. :class:`Commitments` turns the planned
cells into turning actions (forward where the planned cell is ahead, else a turn towards
it) passed through the traffic rule, and keeps the cell each robot turns towards, its
*commitment*, which it plans first, for that cell alone, on the next steps.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.planners.pibt.floor import NIL, PlanningFloor
from warehouse_phys.world.headings import (
    MOVE_HEADINGS,
    TurnAction,
    facing_move,
    quarter_turns,
    turn_towards,
    turning_moves,
)
from warehouse_phys.world.traffic import WAIT


def count_turns(distance: np.ndarray, headings: np.ndarray, at_goal: np.ndarray) -> np.ndarray:
    """Turning robots' candidate values (``(m, 5)``: the four moves by grid action,
    then staying) from the cells' distances: a move costs the quarter turns to face it,
    the move and the cell's distance; staying costs a step more than the best move
    (0 on the goal)."""
    faces = MOVE_HEADINGS[np.arange(WAIT)]
    value = distance.copy()
    value[:, :WAIT] += quarter_turns(headings[:, None], faces[None, :]) + 1
    value[:, WAIT] = value[:, :WAIT].min(axis=1) + 1
    value[at_goal, WAIT] = 0.0
    return value


class Commitments:
    """The cells turning robots are turning towards (the module's docstring), and the
    turning actions of a plan.

    Args:
        floor: The floor.
        corner_follows: Whether traffic grants corner follows.
    """

    def __init__(self, floor: PlanningFloor, corner_follows: bool) -> None:
        self.floor = floor
        self.corner_follows = corner_follows
        #: The cell each robot is turning towards (:data:`NIL`: none), and the goal it
        #: was chosen for.
        self.cell = np.empty(0, dtype=np.int64)
        self.goal = np.empty(0, dtype=np.int64)

    def keep(self, here: np.ndarray, goal: np.ndarray, movable: np.ndarray) -> None:
        """Keep the cells turning robots are turning towards, dropping those reached, no
        longer next to the robot, or made for another goal."""
        n = len(here)
        if len(self.cell) != n:
            self.cell = np.full(n, NIL, dtype=np.int64)
            self.goal = np.full(n, NIL, dtype=np.int64)
        committed = self.cell
        held = committed != NIL
        if held.any():
            beside = (self.floor.table[here, :WAIT] == committed[:, None]).any(axis=1)
            keep = held & beside & (committed != here) & (self.goal == goal) & movable
            committed[~keep] = NIL

    def actions(
        self,
        here: np.ndarray,
        headings: np.ndarray,
        goal: np.ndarray,
        plan: list[int],
        ranked_of: list[Any],
        present: np.ndarray,
        movable: np.ndarray,
        requested: dict[int, int],
    ) -> np.ndarray:
        """Turning robots' actions from the planned cells: forward where the planned cell
        is ahead; a turn towards it (on the shorter side) where it is beside or behind,
        and the robot keeps that cell as its next (a commitment); a robot that stays
        turns towards its best candidate. Passed through the traffic rule, so every
        action is granted."""
        grid = self.floor.grid
        n = len(here)
        moving = np.flatnonzero(movable)
        planned = np.array(plan, dtype=np.int64)
        stays = np.zeros(n, dtype=bool)
        stays[moving] = planned[moving] == here[moving]
        best = np.array([NIL if r is None else r[0] for r in ranked_of], dtype=np.int64)
        target = np.where(stays & (best != NIL), best, planned)  # staying: face the best cell
        target[~movable] = here[~movable]
        move = np.array(self.floor.action_of, dtype=np.int64)[target - here + grid.cols]
        wanted = facing_move(move, headings)
        actions = turn_towards(headings, wanted)
        facing = (wanted == headings) & ~stays & movable
        actions[facing] = TurnAction.FORWARD
        for i, action in requested.items():
            if stays[i]:  # a turn or a wait as asked; a forward move that cannot be made waits
                actions[i] = action if action != TurnAction.FORWARD else TurnAction.WAIT
        grants = turning_moves(grid, here, headings, actions, ~movable & present,
                               corner_follows=self.corner_follows)  # fmt: skip
        actions[grants.refused] = TurnAction.WAIT
        commit = movable & ~stays & ~facing
        commit[list(requested)] = False
        commit |= facing & grants.refused & self.corner_follows  # it goes on the next step
        self.cell[commit] = planned[commit]
        self.goal[commit] = goal[commit]
        self.cell[~commit] = NIL
        return actions
