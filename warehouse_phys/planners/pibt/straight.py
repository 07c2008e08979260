"""PIBT for a fleet without corner follows: pushes in straight lines, priority
inheritance over two steps.

Without corner follows, traffic lets a robot enter an occupied cell only as its occupant
leaves straight ahead, so a push is a line of robots that all step forward together, or
none does. :class:`StraightPushes` plans one robot of
:class:`~warehouse_phys.planners.pibt.PIBT` that way (what ``PIBT(...,
corner_follows=False)`` calls in place of PIBT's recursion): no rotation, which always
turns a corner, is planned, and a robot that cannot be pushed straight on steps aside
instead, leaving its cell empty for the robot behind to enter on the next step.
"""

from __future__ import annotations

from typing import Any

from warehouse_phys.planners.pibt.floor import NIL, PlanningFloor
from warehouse_phys.planners.pibt.swaps import SwapOperation, pull

#: Without corner follows, how many robots of a line in the way are asked to leave it.
_MAX_ASKED = 8


class StraightPushes:
    """PIBT's step for one robot of a fleet without corner follows (the module's
    docstring), on ``floor``, with ``swap``'s swap operation made straight."""

    def __init__(self, floor: PlanningFloor, swap: SwapOperation) -> None:
        self.floor = floor
        self.swap = swap

    def plan_robot(
        self,
        i: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
        occupied_next: list[int],
        suspects: list[bool],
    ) -> None:
        """PIBT for a fleet without corner follows, from robot ``i`` (``suspects``:
        :meth:`SwapOperation.suspects`).

        A robot may enter an occupied cell only as its occupant leaves straight ahead,
        so a push is a line: the robots ahead of ``i`` in the direction of its move all
        step forward together, or the move is not taken. Robots that a push could not
        move are left unplanned (free to go their own way later in the step), not
        pinned to their cells as in PIBT's backtracking. When ``i`` ends up staying put
        because such a line stood on a cell nearer its goal, the line's robots, nearest
        first, inherit ``i``'s priority and the first of them that can leave its cell
        (any way but back) does, and its cell stays empty: on the next step the line
        closes up and ``i`` moves on. Priority inheritance over two steps, where corner
        follows do it in one.

        The swap operation is made straight, for a robot in a pocket (a cell with one way
        out): a robot ``i`` that must let it out (:meth:`SwapOperation.partner`) backs
        away from it in the line of the two, pushing the line behind it, and pulls it on
        after it.
        """
        floor = self.floor
        partner = (
            self.swap.partner(i, here, ranked_of[i], plan, occupied_now) if suspects[i] else NIL
        )
        if partner != NIL and len(floor.exits(here[partner])) == 1:  # a pocket
            away = int(
                floor.table[here[i], floor.action_of[here[i] - here[partner] + floor.grid.cols]]
            )
            if away != here[i]:
                own = ranked_of[i]
                ranked_of[i] = [away]
                line = self._move_straight(i, here, ranked_of, plan, occupied_now, occupied_next)
                ranked_of[i] = own
                if line is None:
                    pull(i, partner, here, plan, occupied_next)
                    return
        line = self._move_straight(i, here, ranked_of, plan, occupied_now, occupied_next)
        if line is None:
            return
        plan[i] = here[i]
        occupied_next[here[i]] = i
        for j in line[:_MAX_ASKED]:
            occupied_next[here[j]] = i  # kept empty: j may not stay
            if self._move_straight(j, here, ranked_of, plan, occupied_now, occupied_next) is None:
                return
            occupied_next[here[j]] = NIL

    def _move_straight(
        self,
        i: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
        occupied_next: list[int],
    ) -> list[int] | None:
        """Plan ``i``'s best candidate that traffic grants without corner follows, pushing
        the line ahead of it straight on, and return None; or, when staying is the best
        left (nothing is planned then), the robots in the way of the first better cell
        that could not be reached, nearest first (perhaps none)."""
        floor = self.floor
        table, action_of, cols, goals = floor.table, floor.action_of, floor.grid.cols, floor.goals
        blocked_by: list[int] = []
        for cell in ranked_of[i]:
            if cell == NIL or occupied_next[cell] != NIL:
                continue
            if cell == here[i]:
                break  # staying is the best that is left
            step = cell - here[i]
            action = action_of[step + cols]
            line, ahead = [], cell  # the unplanned robots to push, and the cell reached
            while True:
                if occupied_next[ahead] != NIL:
                    goes = False  # someone stays or arrives there
                    break
                j = occupied_now[ahead]
                if j == NIL:
                    goes = True
                    break
                if plan[j] != NIL:  # planned already: it must leave straight ahead
                    goes = plan[j] - ahead == step
                    break
                line.append(j)
                onward = int(table[ahead, action])
                if onward == ahead:
                    goes = False  # pushed into a wall or a shelf
                    break
                if len(floor.exits(onward)) == 1 and onward != goals[j]:
                    goes = False  # pushed into a pocket it would have to back out of
                    break
                ahead = onward
            if not goes:
                if not blocked_by:
                    blocked_by = line
                continue
            plan[i] = cell
            occupied_next[cell] = i
            for j in line:
                onward = here[j] + step
                plan[j] = onward
                occupied_next[onward] = j
            return None
        return blocked_by
