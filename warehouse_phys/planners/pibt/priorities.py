"""PIBT's priorities: a robot's grows each step it spends on its way to the same goal.

:func:`grow_priorities` is the rule that both PIBT (:class:`~warehouse_phys.planners.pibt.PIBT`)
and PIBT over operations (:class:`~warehouse_phys.planners.operations.OperationPIBT`)
order their robots by: a robot that waits long enough comes first, which is how PIBT
reaches every goal.
"""

from __future__ import annotations

import numpy as np


def grow_priorities(
    priority: np.ndarray | None,
    goals_before: np.ndarray | None,
    here: np.ndarray,
    goal: np.ndarray,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """PIBT's priorities after one more step: each robot still on its way to the same goal
    gains one; a robot with a new goal (or on its goal) falls back to its tie-breaker, the
    fraction drawn from ``rng`` on the first step (``priority`` None). Returns the
    priorities (updated in place) and the goals to pass next time.

    Raises:
        ValueError: if the number of robots changed.
    """
    n = len(here)
    if priority is None:
        return rng.random(n), goal.copy()
    if len(priority) != n:
        raise ValueError(
            f"this planner planned for {len(priority)} robots, now {n}: "
            "use a new planner for a new fleet"
        )
    fresh = (goal != goals_before) | (here == goal)
    priority[fresh] -= np.floor(priority[fresh])
    priority[~fresh] += 1
    return priority, goal.copy()
