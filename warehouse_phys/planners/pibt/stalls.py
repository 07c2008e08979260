"""When a planner over operations should hand its fleet over to PIBT: once its robots stop
driving forward.

PIBT over operations (:class:`~warehouse_phys.planners.operations.OperationPIBT`) has no
swap operation: on floors full of dead ends (the LoRR main rounds' random floors) two
turning robots can face each other at a dead end's mouth for ever, the robots behind them
pile up, and the fleet's forward moves fall away to none (2024 RANDOM-03, 400 robots: from
45 % of the actions to 0 % between steps 250 and 500). One-step PIBT makes the swap
operation (:class:`~warehouse_phys.planners.pibt.PIBT`) and does not jam there.
:class:`StallWatch` tells the planner over operations when to hand over to it
(:class:`~warehouse_phys.planners.guidance.GuidedPIBT`).

The measure is relative to the run itself, so that it holds on any floor: a fleet on a
dense floor that always drives forward less than one on an open floor is not a stall;
a fleet that drives forward half as much as it once did is. What it does not see: a
gridlock in one part of a floor while the rest drives on (2024 WAREHOUSE, 10,000 robots
over operations: 803 robots still for 50 steps in the one-cell aisles by the stations,
and the fleet's forward share 71 % against its best 84 %; ``docs/lorr.md``). Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
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


class StallWatch:
    """Watches a turning fleet's plans for a stall (the module's docstring): the share
    of its moving robots sent forward, averaged over the last ``window`` plans, below
    ``fraction`` of the best such average so far. O(N) a plan, O(``window``) memory.

    Args:
        window: Plans averaged over (>= 1).
        fraction: Of the best average so far, 0 to 1.

    Raises:
        ValueError: for a window below 1 or a fraction outside 0..1.
    """

    def __init__(self, window: int = STALL_WINDOW, fraction: float = STALL_FRACTION) -> None:
        if isinstance(window, bool) or not isinstance(window, int) or window < 1:
            raise ValueError(f"window must be an integer >= 1, got {window!r}")
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"fraction must be 0 to 1, got {fraction!r}")
        self.window = window
        self.fraction = float(fraction)
        self._shares: deque[float] = deque(maxlen=window)
        #: The best average over ``window`` plans so far.
        self.best = 0.0
        #: Whether the fleet has stalled (once it has, it stays so).
        self.stalled = False

    def observe(self, actions: np.ndarray, movable: np.ndarray) -> bool:
        """Take one plan (turning actions, ``(N,)``; ``movable``: the robots it moves) and
        say whether the fleet has stalled on it (:attr:`stalled` keeps the first time)."""
        moving = np.asarray(movable, dtype=bool)
        count = int(moving.sum())
        if not count:  # nothing planned: no evidence either way
            return False
        forward = int((np.asarray(actions)[moving] == TurnAction.FORWARD).sum())
        self._shares.append(forward / count)
        if len(self._shares) < self.window:
            return False
        average = sum(self._shares) / self.window
        self.best = max(self.best, average)
        stalled = average < self.fraction * self.best
        self.stalled |= stalled
        return stalled
