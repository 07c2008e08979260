"""The start kit's robots: squares of side ``agentSize`` swept linearly through each tick,
and when two of them collide (League of Robot Runners 2026, the competition's own rule).

The start kit (3.1.0, ``src/ActionModel.cpp``) places robot ``i`` as an axis-aligned
square of side ``s`` (the instance's ``agentSize``, 1 when not given) whose corner of
least ``x`` (column) and ``y`` (row) is at ``(col, row)`` of the cell it is on, plus,
during a forward move, ``count / maxCount`` of the way along its heading (a turn does
not move the square). Within a tick each square moves linearly from where it is to
where the tick leaves it (a move that ends is on its new cell exactly). Two robots
*collide* in a tick when their swept squares overlap with positive area at some instant
of it: touching squares do not collide. The kit computes this in single precision
(``float``) with a tolerance of ``1e-6`` (``moving_boxes_collide`` and
``intersect_open_linear_interval``); :func:`boxes_collide` is that computation restated
in ``numpy.float32``, operation for operation, so that it gives the kit's verdict bit for
bit (the kit is built without fast-math, and x86-64 single-precision arithmetic is
IEEE's, as numpy's). Near-touching squares far from the origin are where the rounding
matters: at column 500 a float's step is 6e-5, far above the tolerance, so two robots
that touch in exact arithmetic may collide in the kit's.

:func:`square_corners` is a robot's square from the executor's arrays, and
:func:`may_follow_squares` the executor's follow rule for such robots: whether a robot
may advance a tick into the cell its leader is leaving so that their squares never
collide, whatever the leader does that tick. The kit draws a tick's delays after the
executor's commands, so a command must be safe both if the leader advances and if it
stands still; no robot follows "together" with its leader (see
:mod:`~warehouse_phys.execution.following`, which chooses this rule or the discs').

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numbers

import numpy as np

#: The kit's tolerance in its interval test [cells, and its share of a tick].
KIT_EPS = np.float32(1e-6)
_ZERO, _ONE = np.float32(0.0), np.float32(1.0)


def checked_size(size: object) -> float:
    """``size`` (``agentSize``) as a float in ``(0, 1]`` cells, or a one-line error.

    Raises:
        TypeError: for anything but a real number.
        ValueError: outside ``(0, 1]``: squares larger than a cell overlap robots at rest
            on neighbouring cells, which no executor can run.
    """
    if isinstance(size, (bool, np.bool_)) or not isinstance(size, numbers.Real):
        raise TypeError(f"agent_size must be a real number of cells, got {size!r}")
    value = float(size)
    if not 0 < value <= 1:  # NaN fails too
        raise ValueError(f"agent_size must be above 0 and at most 1 cell, got {size!r}")
    return value


def square_corners(
    left: np.ndarray, entered: np.ndarray, done: np.ndarray, needed: np.ndarray, cols: int
) -> np.ndarray:
    """``(K, 2)`` float32 ``(x, y)``: the corner of each robot's square as the kit places
    it (``ActionModelWithRotate::get_real_locations``): the column and row of the cell it
    is on (``left``), moved ``done / needed`` of the way towards ``entered`` in mid-move.

    ``left`` and ``entered`` are ``(K,)`` cell indices (``row * cols + col``; the same
    cell at rest or in a turn), ``done`` the ticks done of the current move (0 at rest),
    ``needed`` the ticks it takes.
    """
    row, col = np.divmod(np.asarray(left, dtype=np.int64), cols)
    to_row, to_col = np.divmod(np.asarray(entered, dtype=np.int64), cols)
    done = np.asarray(done)
    frac = np.asarray(done, np.float32) / np.asarray(needed, np.float32)
    moving = done > 0
    x, y = col.astype(np.float32), row.astype(np.float32)
    # The kit adds or subtracts the share along the heading: x += frac east, x -= frac west.
    x = np.where(moving & (to_col > col), x + frac, np.where(moving & (to_col < col), x - frac, x))
    y = np.where(moving & (to_row > row), y + frac, np.where(moving & (to_row < row), y - frac, y))
    return np.stack([x, y], axis=1).astype(np.float32)


def corners_after_tick(
    left: np.ndarray, entered: np.ndarray, done: np.ndarray, needed: np.ndarray, cols: int
) -> np.ndarray:
    """``(K, 2)`` float32: where each square is after advancing one tick of its move
    towards ``entered`` (on ``entered`` exactly when the tick ends the move)."""
    done = np.asarray(done) + 1
    ends = done >= np.asarray(needed)
    return square_corners(np.where(ends, entered, left), entered, np.where(ends, 0, done),
                          needed, cols)  # fmt: skip


def boxes_collide(
    a_start: np.ndarray, a_end: np.ndarray, b_start: np.ndarray, b_end: np.ndarray, size: float
) -> np.ndarray:
    """``(K,)`` bool: whether squares of side ``size`` moving linearly from ``a_start`` to
    ``a_end`` and from ``b_start`` to ``b_end`` (``(K, 2)`` ``(x, y)`` corners) collide
    within the tick, by the kit's ``moving_boxes_collide`` in single precision."""
    s = np.float32(size)
    a0, a1 = np.asarray(a_start, np.float32), np.asarray(a_end, np.float32)
    b0, b1 = np.asarray(b_start, np.float32), np.asarray(b_end, np.float32)
    # The swept rectangles must overlap first (strictly).
    a_low, a_high = np.minimum(a0, a1), np.maximum(a0, a1) + s
    b_low, b_high = np.minimum(b0, b1), np.maximum(b0, b1) + s
    swept = ((a_low < b_high) & (a_high > b_low)).all(axis=1)
    d0 = a0 - b0
    dv = (a1 - a0) - (b1 - b0)
    t0x, t1x, x_ok = _open_interval(d0[:, 0], dv[:, 0], -s, s)
    t0y, t1y, y_ok = _open_interval(d0[:, 1], dv[:, 1], -s, s)
    return swept & x_ok & y_ok & (np.maximum(t0x, t0y) <= np.minimum(t1x, t1y))


def _open_interval(
    d0: np.ndarray, dv: np.ndarray, lower: np.float32, upper: np.float32
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kit's ``intersect_open_linear_interval``: the share ``[t0, t1]`` of the tick in
    which ``d0 + dv t`` lies in ``(lower, upper)`` with the kit's tolerance, and whether
    it is not empty (float32, operation for operation)."""
    still = (dv > -KIT_EPS) & (dv < KIT_EPS)
    inside = (d0 > lower + KIT_EPS) & (d0 < upper - KIT_EPS)
    with np.errstate(divide="ignore", invalid="ignore"):
        safe = np.where(still, _ONE, dv)
        t0 = (lower - d0) / safe
        t1 = (upper - d0) / safe
        t0, t1 = np.minimum(t0, t1), np.maximum(t0, t1)
        teps = KIT_EPS / np.abs(safe)
    t0 = np.maximum(_ZERO, t0 + teps)
    t1 = np.minimum(_ONE, t1 - teps)
    t0 = np.where(still, _ZERO, t0).astype(np.float32)
    t1 = np.where(still, _ONE, t1).astype(np.float32)
    ok = np.where(still, inside, t0 <= t1)
    return t0, t1, ok


def may_follow_squares(
    followers: np.ndarray,
    leaders: np.ndarray,
    left: np.ndarray,
    target: np.ndarray,
    done: np.ndarray,
    needed: np.ndarray,
    cols: int,
    size: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Whether each follower may advance a tick into the cell its leader is leaving, as
    :func:`~warehouse_phys.execution.following.may_follow` says for discs, for squares of
    side ``size``: its swept square collides (:func:`boxes_collide`) neither with the
    leader's standing still nor with the leader's advancing, the leader is in mid-move,
    and the follower does not end its move while the leader has not left. The second
    answer ("together": only if the leader advances) is always ``False``: the kit draws
    a tick's delays after the commands, so no command may count on another robot moving.

    Arguments as :func:`~warehouse_phys.execution.following.may_follow`'s, ``target``
    being each robot's cell of its current or next move. Returns ``(K,)`` bool twice.
    """
    f_from = square_corners(left[followers], target[followers], done[followers],
                            needed[followers], cols)  # fmt: skip
    f_to = corners_after_tick(left[followers], target[followers], done[followers],
                              needed[followers], cols)  # fmt: skip
    l_now = square_corners(left[leaders], target[leaders], done[leaders], needed[leaders], cols)
    l_next = corners_after_tick(left[leaders], target[leaders], done[leaders], needed[leaders],
                                cols)  # fmt: skip
    clear = ~boxes_collide(f_from, f_to, l_now, l_now, size)
    clear &= ~boxes_collide(f_from, f_to, l_now, l_next, size)
    arrives = done[followers] + 1 == needed[followers]
    alone = (done[leaders] > 0) & ~arrives & clear
    return alone, np.zeros_like(alone)


def colliding_pairs(
    start: np.ndarray, end: np.ndarray, cells: np.ndarray, size: float, cols: int
) -> np.ndarray:
    """``(P, 2)`` the pairs of robots (lower first) whose squares collide within a tick, as
    the kit's action model would find them: every robot against those whose cell is
    within two cells of its own (the kit's neighbourhood is one cell plus ``size``).

    ``start`` and ``end`` are ``(N, 2)`` float32 corners before and after the tick
    (:func:`square_corners`), ``cells`` ``(N,)`` each robot's cell index (the one it is
    on or leaves) before the tick. O(N log N).
    """
    cells = np.asarray(cells, dtype=np.int64)
    n = len(cells)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    row, col = np.divmod(cells, cols)
    order = np.argsort(cells, kind="stable")
    ranked = cells[order]
    pairs = []
    for d_row in range(-2, 3):
        for d_col in range(-2, 3):
            other_row, other_col = row + d_row, col + d_col
            inside = (other_col >= 0) & (other_col < cols) & (other_row >= 0)
            wanted = other_row * cols + other_col
            spot = np.searchsorted(ranked, wanted)
            spot = np.minimum(spot, n - 1)
            found = inside & (ranked[spot] == wanted)
            a = np.flatnonzero(found)
            b = order[spot[found]]
            keep = a < b
            pairs.append(np.stack([a[keep], b[keep]], axis=1))
    both = np.concatenate(pairs)
    if not len(both):
        return both
    hit = boxes_collide(start[both[:, 0]], end[both[:, 0]], start[both[:, 1]], end[both[:, 1]],
                        size)  # fmt: skip
    return both[hit]
