"""The follow rule: whether a robot may advance a tick into the cell the robot ahead of it
(its leader) is leaving.

This is the one rule of :class:`~warehouse_phys.execution.executor.Executor` that says
whether a robot may enter a cell another still holds: the dependency graph says whom a
robot follows, :func:`follow_permits` says whether it may advance now, by the robots'
shape:

- **discs** (our model: our own floors and the physics twin; :func:`may_follow`): centres
  kept :data:`DEFAULT_MIN_GAP` (or the executor's ``min_gap``) apart all tick. Centres are
  points that move linearly within a tick (the grid twin's nominal positions); the gap is
  the least distance between them over the tick
  (:func:`~warehouse_phys.execution.async_grid.closest_squared`).
- **squares** of side ``agentSize`` (the League of Robot Runners' 2026 model, on its
  instances; :func:`~warehouse_phys.execution.swept_squares.may_follow_squares`): the
  start kit's swept squares never collide, whatever the leader does in the tick.
"""

from __future__ import annotations

import math

import numpy as np

from warehouse_phys.execution.async_grid import GAP_SLACK, closest_squared
from warehouse_phys.execution.swept_squares import may_follow_squares

#: Closest two robots' centres come by default [cells]: two robots that follow each
#: other round a corner at the same pace pass this close (half a cell each way), so
#: with moves of one tick every lock-step plan, corner follows included, runs as planned.
DEFAULT_MIN_GAP = math.sqrt(0.5)


def may_follow(
    followers: np.ndarray,
    leaders: np.ndarray,
    left: np.ndarray,
    target: np.ndarray,
    done: np.ndarray,
    needed: np.ndarray,
    cols: int,
    min_gap: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Whether each follower may advance a tick into the cell its leader is leaving
    with the leader standing still (which needs the leader in mid-move), and with the
    leader advancing too: whether the two centres stay ``min_gap`` apart all tick.

    ``followers`` and ``leaders`` are ``(K,)`` robot numbers, pair by pair; ``left``
    (the cell each robot is on or leaves), ``target`` (the cell its move enters),
    ``done`` (ticks done of its move) and ``needed`` (ticks its move takes) are ``(N,)``
    over the fleet, cells as indices ``row * cols + col``. Returns ``(K,)`` bool twice:
    may go alone, may go together with its leader.
    """
    step_f = _unit(left[followers], target[followers], cols)
    step_l = _unit(left[leaders], target[leaders], cols)
    f0 = done[followers] / needed[followers]
    f1 = (done[followers] + 1) / needed[followers]
    l0 = done[leaders] / needed[leaders]
    l1 = (done[leaders] + 1) / needed[leaders]
    # Leader minus follower, from the cell between them: l * step_l + (1 - f) * step_f.
    start = l0[:, None] * step_l + (1 - f0)[:, None] * step_f
    still = l0[:, None] * step_l + (1 - f1)[:, None] * step_f
    both = l1[:, None] * step_l + (1 - f1)[:, None] * step_f
    least = min_gap**2 * (1 - GAP_SLACK)
    # A follower ends its move (at rest on the cell) only as or after its leader's
    # move ends: a cell is left by one robot at a time, and a robot at rest holds its
    # cell alone.
    arrives = done[followers] + 1 == needed[followers]
    leaves = done[leaders] + 1 == needed[leaders]
    alone = (done[leaders] > 0) & ~arrives & (closest_squared(start, still) >= least)
    together = (~arrives | leaves) & (closest_squared(start, both) >= least)
    return alone, together


def follow_permits(
    followers: np.ndarray,
    leaders: np.ndarray,
    left: np.ndarray,
    target: np.ndarray,
    done: np.ndarray,
    needed: np.ndarray,
    cols: int,
    min_gap: float,
    agent_size: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`may_follow` for discs kept ``min_gap`` apart (``agent_size`` ``None``), else
    :func:`~warehouse_phys.execution.swept_squares.may_follow_squares` for squares of side
    ``agent_size``; the same arguments and answers (may go alone, may go with its leader)."""
    if agent_size is None:
        return may_follow(followers, leaders, left, target, done, needed, cols, min_gap)
    return may_follow_squares(followers, leaders, left, target, done, needed, cols, agent_size)


def _unit(start: np.ndarray, end: np.ndarray, cols: int) -> np.ndarray:
    """``(K, 2)`` float ``(d_row, d_col)`` of moves between cell indices (0 for no move)."""
    rows_start, cols_start = np.divmod(start, cols)
    rows_end, cols_end = np.divmod(end, cols)
    return np.stack([rows_end - rows_start, cols_end - cols_start], axis=1).astype(np.float64)
