"""When a planner over operations should hand its fleet over to PIBT (once its robots stop
driving forward) and when back (once its jam has cleared).

PIBT over operations (:class:`~warehouse_phys.planners.operations.OperationPIBT`) has no
swap operation: on floors full of dead ends (the LoRR main rounds' random floors) two
turning robots can face each other at a dead end's mouth for ever, the robots behind them
pile up, and the fleet's forward moves fall away to none (2024 RANDOM-03, 400 robots: from
45 % of the actions to 0 % between steps 250 and 500). One-step PIBT makes the swap
operation (:class:`~warehouse_phys.planners.pibt.PIBT`) and does not jam there.
:class:`StallWatch` tells the planner over operations when to hand over to it
(:class:`~warehouse_phys.planners.guidance.GuidedPIBT`).

It watches two measures; either one is a stall:

- **The fleet's forward share**, relative to the run itself, so that it holds on any
  floor: a fleet on a dense floor that always drives forward less than one on an open
  floor is not a stall; a fleet that drives forward half as much as it once did is.
- **Robots standing still away from their goals**, which the forward share misses: a
  gridlock in one part of a floor while the rest drives on (2024 WAREHOUSE, 10,000
  robots over operations: 803 robots that had not left their cells for 50 steps in the
  one-cell aisles by the stations, and the fleet's forward share 71 % against its best
  84 %; ``docs/lorr.md``). A jam holds many such robots and a moving fleet few: over
  operations, 15-38 % of the robots on the 2024 random floors before their forward share
  fell, against none on the start kit's random-example_400 over 1,000 steps and 2-5 %
  there on the kit's ticks with delays. Hence 5 %.

A jam that one-step PIBT has undone leaves the fleet better off over operations again
(2024 RANDOM-02 and -03, ``guided-ops-repair``: 1.635 and 1.587 tasks a step handing
back, against 1.498 and 1.490 handing over for good), so the watch also says when the
jam has cleared: no robot still for ``calm_plans`` (50) plans in a row, or in a fleet of
a thousand robots or more no more than ``calm_share`` (0.1 %) of them
(:meth:`StallWatch.cleared`), and the planner hands back. Requiring none in a large fleet
kept 2024 WAREHOUSE's 10,000 robots handed over from step 3,367 to the end of 5,000
steps, a few robots stuck somewhere while the rest drove on.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from warehouse_phys.world.headings import TurnAction

#: Plans averaged over [plans].
STALL_WINDOW = 20
#: The share of the best average so far below which the fleet has stalled.
STALL_FRACTION = 0.5
#: Plans a robot away from its goal keeps its cell before it counts as still [plans].
STILL_PLANS = 50
#: The share of the moving robots above which still robots are a stall.
STILL_SHARE = 0.05
#: Plans in a row with no more still robots than ``calm_share`` of the moving ones after
#: which a stalled fleet's jam has cleared [plans].
CALM_PLANS = 50
#: The share of the moving robots that may still stand still in a jam that has cleared:
#: below one robot for fleets under 1,000 (none may), ten of 10,000.
CALM_SHARE = 0.001


class StallWatch:
    """Watches a turning fleet's plans for a stall (the module's docstring): the share
    of its moving robots sent forward, averaged over the last ``window`` plans, below
    ``fraction`` of the best such average so far; or, where the plans come with the
    robots' cells and goals, more than ``still_share`` of the moving robots away from
    their goals on the cells they stood on ``still_plans`` plans before and at every
    plan since. Handed over, the fleet is watched for its jam to clear (:meth:`cleared`).
    O(N) a plan, O(N + ``window``) memory.

    Args:
        window: Plans averaged over (>= 1).
        fraction: Of the best average so far, 0 to 1.
        still_plans: Plans a robot keeps its cell before it counts as still (>= 1).
        still_share: Of the moving robots, 0 to 1.
        calm_plans: Plans in a row with at most ``calm_share`` of the moving robots still
            before a jam has cleared (>= 1).
        calm_share: Of the moving robots, 0 to 1.

    Raises:
        ValueError: for a window, ``still_plans`` or ``calm_plans`` below 1, or a fraction or
            ``still_share`` or ``calm_share`` outside 0..1.
    """

    def __init__(
        self,
        window: int = STALL_WINDOW,
        fraction: float = STALL_FRACTION,
        *,
        still_plans: int = STILL_PLANS,
        still_share: float = STILL_SHARE,
        calm_plans: int = CALM_PLANS,
        calm_share: float = CALM_SHARE,
    ) -> None:
        for name, value in (("window", window), ("still_plans", still_plans),
                            ("calm_plans", calm_plans)):  # fmt: skip
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        for name, value in (("fraction", fraction), ("still_share", still_share),
                            ("calm_share", calm_share)):  # fmt: skip
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be 0 to 1, got {value!r}")
        self.window = window
        self.fraction = float(fraction)
        self.still_plans = still_plans
        self.still_share = float(still_share)
        self.calm_plans = calm_plans
        self.calm_share = float(calm_share)
        self._shares: deque[float] = deque(maxlen=window)
        #: The best average over ``window`` plans so far.
        self.best = 0.0
        #: Each robot's plans on its cell away from its goal so far (None: no cells yet).
        self.still: np.ndarray | None = None
        self._cells: np.ndarray | None = None
        #: Whether the fleet has stalled (until :meth:`cleared` says its jam has cleared).
        self.stalled = False
        self._calm = 0

    def observe(
        self,
        actions: np.ndarray,
        movable: np.ndarray,
        here: np.ndarray | None = None,
        goal: np.ndarray | None = None,
    ) -> bool:
        """Take one plan (turning actions, ``(N,)``; ``movable``: the robots it moves;
        optionally ``here`` and ``goal``, each robot's cell and goal as cell indices,
        ``(N,)``) and say whether the fleet has stalled on it (:attr:`stalled` keeps it
        until :meth:`cleared`)."""
        moving = np.asarray(movable, dtype=bool)
        count = int(moving.sum())
        still = here is not None and goal is not None and self._count_still(here, goal, moving)
        if not count:  # nothing planned: no evidence either way
            return False
        stalled = still > self.still_share * count
        forward = int((np.asarray(actions)[moving] == TurnAction.FORWARD).sum())
        self._shares.append(forward / count)
        if len(self._shares) == self.window:
            average = sum(self._shares) / self.window
            self.best = max(self.best, average)
            stalled |= average < self.fraction * self.best
        self.stalled |= stalled
        return stalled

    def cleared(self, here: np.ndarray, goal: np.ndarray, movable: np.ndarray) -> bool:
        """Take one plan of a stalled fleet handed over (each robot's cell and goal as cell
        indices, ``(N,)``; ``movable``: the robots planned) and say whether its jam has
        cleared: no more moving robots still (as :meth:`observe` counts them) than
        ``calm_share`` of the moving robots at each of the last ``calm_plans`` plans. Once
        it has, the watch starts again as new, for the planner handed back (not
        :attr:`stalled`, no best share, no robot still)."""
        moving = np.asarray(movable, dtype=bool)
        still = self._count_still(here, goal, moving)
        calm = still <= self.calm_share * int(moving.sum())
        self._calm = self._calm + 1 if calm else 0
        if self._calm < self.calm_plans:
            return False
        self._shares.clear()
        self.best, self.stalled, self._calm = 0.0, False, 0
        self.still = self._cells = None
        return True

    def _count_still(self, here: np.ndarray, goal: np.ndarray, moving: np.ndarray) -> int:
        """Count a plan for each moving robot away from its goal on the cell it stood on at
        the last plan (the others start again from 0); return how many have counted
        ``still_plans`` plans."""
        here = np.asarray(here, dtype=np.int64)
        kept = moving & (here != np.asarray(goal, dtype=np.int64))
        if self.still is None or self._cells is None or len(self._cells) != len(here):
            self.still = np.zeros(len(here), dtype=np.int64)  # a new fleet: nothing seen
            kept[:] = False
        else:
            kept &= here == self._cells
        self.still = np.where(kept, self.still + 1, 0)
        self._cells = here.copy()
        return int((self.still >= self.still_plans).sum())
