"""PIBT's swap operation (Okumura 2023, LaCAM*'s PIBT): two robots that meet in a
corridor pass each other where it opens.

A robot whose best cell holds a robot that can only get out through its own cell (a
corridor closed at the far end, a pocket left by parked robots) steps back, away from its
goal, and pulls that robot into its cell, so the two pass each other where the corridor
opens instead of facing each other for ever. :class:`SwapOperation` says which robot must
let which pass (over the floor's exits round the held cells,
:class:`~warehouse_phys.planners.pibt.floor.PlanningFloor`); :func:`pull` is the
operation's second half. :class:`~warehouse_phys.planners.pibt.PIBT` makes it with corner
follows, and straight (:mod:`warehouse_phys.planners.pibt.straight`) without them.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.planners.pibt.floor import NIL, PlanningFloor


class SwapOperation:
    """Who must let whom pass on one floor (the module's docstring).

    Args:
        floor: The floor, the cells held on it now and the robots' distances
            (:meth:`~warehouse_phys.planners.pibt.floor.PlanningFloor.distance`).
    """

    def __init__(self, floor: PlanningFloor) -> None:
        self.floor = floor

    def suspects(
        self,
        here: np.ndarray,
        present: np.ndarray,
        moving: np.ndarray,
        requested: dict,
        first_choice: np.ndarray,
    ) -> list[bool]:
        """Which robots :meth:`partner` must look at: those whose first choice (each
        moving robot's best candidate, :data:`NIL` for none) is a cell another robot
        stands on now with at most two ways out (the conditions of a swap that do not
        change during the step, tested for all robots at once), and those asked to move
        (their one candidate is the request)."""
        suspect = np.zeros(len(here), dtype=bool)
        occupant = np.full(len(self.floor.table), NIL, dtype=np.int64)
        occupant[here[present]] = np.flatnonzero(present)
        best = first_choice
        chosen = best != NIL
        best = np.where(chosen, best, 0)
        suspect[moving] = (
            chosen
            & (best != here[moving])
            & (occupant[best] != NIL)
            & (self.floor.exit_count[best] <= 2)
        )
        suspect[list(requested)] = True
        return suspect.tolist()

    def partner(
        self, i: int, here: list[int], ranked: list[int], plan: list[int], occupied_now: list[int]
    ) -> int:
        """The robot that ``i`` should let pass by stepping back (PIBT's swap operation,
        Okumura 2023), or :data:`NIL`: a robot ``j`` in ``i``'s way whose only way out runs
        through ``i``'s cell (a corridor closed at the far end, or one with no room to
        pass), where pushing ``j`` on can never succeed. ``i`` then steps away from its
        goal and pulls ``j`` into its cell; the two pass each other where the corridor
        opens."""
        best = next((cell for cell in ranked if cell != NIL), NIL)
        if best == NIL or best == here[i]:
            return NIL
        j = occupied_now[best]
        if (
            j != NIL
            and plan[j] == NIL
            and len(self.floor.exits(best)) <= 2
            and self._required(i, j, here[i], here[j])
            and self._possible(here[j], here[i])
        ):
            return j
        return NIL

    def _required(self, pusher: int, puller: int, v_pusher: int, v_puller: int) -> bool:
        """Whether ``pusher``, pushing ``puller`` on towards its own goal along a corridor,
        would run into the corridor's closed end short of its goal, and ``puller`` wants
        to come back out. (LaCAM*'s test also swaps when the push would carry ``puller``
        past its goal; on our floors that turned two robots in an aisle back and forth
        for ever, so a swap here is made only where pushing cannot work.)"""
        distance = self.floor.distance
        for _ in range(len(self.floor.table)):
            if distance(pusher, v_puller) >= distance(pusher, v_pusher):
                return False  # pushing on takes the pusher home
            ahead = [cell for cell in self.floor.exits(v_puller) if cell != v_pusher]
            if len(ahead) >= 2:
                return False  # room to pass
            if not ahead:  # the closed end
                return distance(puller, v_pusher) < distance(puller, v_puller)
            v_pusher, v_puller = v_puller, ahead[0]
        return False

    def _possible(self, v_pusher: int, v_puller: int) -> bool:
        """Whether the robot on ``v_puller``, backing away from ``v_pusher`` along the
        corridor, reaches a cell with room for the other to pass."""
        origin = v_pusher
        for _ in range(len(self.floor.table)):
            if v_puller == origin:
                return False  # round a loop
            behind = [cell for cell in self.floor.exits(v_puller) if cell != v_pusher]
            if len(behind) >= 2:
                return True
            if not behind:
                return False
            v_pusher, v_puller = v_puller, behind[0]
        return False


def pull(i: int, partner: int, here: list[int], plan: list[int], occupied_next: list[int]) -> None:
    """The swap operation's second half: ``i`` has moved off its cell, and ``partner``,
    if not planned yet, follows it there."""
    if partner != NIL and plan[partner] == NIL and occupied_next[here[i]] == NIL:
        plan[partner] = here[i]
        occupied_next[here[i]] = partner
