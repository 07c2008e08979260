"""The compiled kernels of PIBT over operations (:mod:`warehouse_phys.planners.operations`).

:class:`~warehouse_phys.planners.operations.OperationPIBT` plans every robot's operation
(a sequence of turning actions) each step; the loops over robots, operations and their
actions whose next step depends on the last are here, compiled with Numba (cached on
disk after the first run): where each operation takes its robot (``_operation_paths``),
what it is worth (``_operation_values``), the reservations of cells and moves at each
depth (``_conflict``, ``_reserve``, ``_reserve_all``) and PIBT's priority
inheritance over them (``_operation_pibt``). They are the operations module's own
(hence their leading underscores): pure, they read the arrays they are given and write
only those they are told to.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Scale of the tie-breaks among operations of equal value [steps]: far below one step.
_TIE_COST = 1e-3


@njit(cache=True, nogil=True)
def _operation_paths(
    here: np.ndarray,
    heading: np.ndarray,
    robots: np.ndarray,
    table: np.ndarray,
    heading_moves: np.ndarray,
    ops: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    valid: np.ndarray,
) -> None:
    """Where each of ``robots`` stands and faces after each action of every operation
    (``cells``, ``heads``: ``(N, K, depth)``), and whether no forward move of it runs
    into a wall or a shelf (``valid``, ``(N, K)``)."""
    for r in range(robots.shape[0]):
        i = robots[r]
        for k in range(ops.shape[0]):
            cell, head, ok = here[i], heading[i], True
            for d in range(ops.shape[1]):
                action = ops[k, d]
                if action == 0:
                    ahead = table[cell, heading_moves[head]]
                    if ahead == cell:
                        ok = False
                        break
                    cell = ahead
                elif action == 1:
                    head = (head + 1) % 4
                elif action == 2:
                    head = (head + 3) % 4
                cells[i, k, d] = cell
                heads[i, k, d] = head
            valid[i, k] = ok


@njit(cache=True, nogil=True)
def _operation_values(
    here: np.ndarray,
    goal: np.ndarray,
    robots: np.ndarray,
    cols: int,
    table: np.ndarray,
    move_headings: np.ndarray,
    ops: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    valid: np.ndarray,
    slot_of: np.ndarray,
    reach: int,
    local: np.ndarray,
    values: np.ndarray,
) -> None:
    """Each valid operation's value (the module's docstring) into ``values`` (``(N, K)``,
    ``inf`` for invalid ones), from ``local``, the values of the cells about each robot
    (``(N, M)``, slots by ``slot_of[(row offset + reach) * (2 reach + 1) + col offset +
    reach]``)."""
    depth = ops.shape[1]
    side = 2 * reach + 1
    here_slot = slot_of[reach * side + reach]
    for r in range(robots.shape[0]):
        i = robots[r]
        row0, col0 = here[i] // cols, here[i] % cols
        for k in range(ops.shape[0]):
            if not valid[i, k]:
                values[i, k] = np.inf
                continue
            value = np.inf
            for d in range(depth):
                if cells[i, k, d] == goal[i]:
                    value = d + 1.0
                    break
            progress = 0.0
            if value == np.inf:
                end, head = cells[i, k, depth - 1], heads[i, k, depth - 1]
                slot = slot_of[(end // cols - row0 + reach) * side + end % cols - col0 + reach]
                progress = min(max(local[i, slot] - local[i, here_slot], -reach), reach)
                for move in range(4):
                    beside = table[end, move]
                    if beside == end:
                        continue
                    slot = slot_of[(beside // cols - row0 + reach) * side
                                   + beside % cols - col0 + reach]  # fmt: skip
                    turns = (move_headings[move] - head) % 4
                    turns = min(turns, 4 - turns)
                    value = min(value, depth + turns + 1.0 + local[i, slot])
            last_move, delays = -1, 0
            for d in range(depth):
                if ops[k, d] != 3:
                    last_move = d
            for d in range(last_move):
                delays += ops[k, d] == 3
            # Among equals: the last cell nearest the goal (what the end's turns leave out
            # of the value), then fewest waits before the last action, then fewest actions.
            values[i, k] = value + _TIE_COST * (10 * progress + delays
                                                  + (last_move + 1 - delays) / 8)  # fmt: skip


@njit(cache=True, nogil=True)
def _rank_operations(
    values: np.ndarray, valid: np.ndarray, robots: np.ndarray, ranked: np.ndarray
) -> None:
    """Each of ``robots``' valid operations best first into ``ranked`` (``(N, K)``, -1
    after the last), by value, ties by the operations' order (no draw)."""
    for i in robots:
        order = np.argsort(values[i], kind="mergesort")
        j = 0
        for k in order:
            if valid[i, k]:
                ranked[i, j] = k
                j += 1
        for rest in range(j, ranked.shape[1]):
            ranked[i, rest] = -1


@njit(cache=True, nogil=True)
def _conflict(
    r: int,
    k: int,
    here: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
    standing: np.ndarray,
    corner_follows: bool,
) -> int:
    """The one robot whose reservations operation ``k`` of robot ``r`` meets: -1 none,
    -2 more than one."""
    found = -1
    prev = here[r]
    for d in range(cells.shape[2]):
        cell = cells[r, k, d]
        owners = (at[cell, d], -1, -1, -1)
        if cell != prev:
            move = heading_moves[heads[r, k, d]]
            owners = (at[cell, d], leaving[cell * 4 + (move + 2) % 4, d], -1, -1)
            if not corner_follows:  # no robot follows another: into a cell held a step
                if d == 0:  # before, or entered as this robot leaves its cell
                    if standing[cell] >= 0:  # it stands there whatever it plans
                        return -2
                else:
                    owners = (owners[0], owners[1], at[cell, d - 1], at[prev, d])
        for owner in owners:
            if owner >= 0 and owner != r:
                if found == -1:
                    found = owner
                elif found != owner:
                    return -2
        prev = cell
    return found


@njit(cache=True, nogil=True)
def _reserve(
    r: int,
    k: int,
    who: int,
    here: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
) -> None:
    """Write ``who`` (``r``, or -1 to free them) into operation ``k``'s reservations."""
    prev = here[r]
    for d in range(cells.shape[2]):
        cell = cells[r, k, d]
        at[cell, d] = who
        if cell != prev:
            leaving[prev * 4 + heading_moves[heads[r, k, d]], d] = who
        prev = cell


@njit(cache=True, nogil=True)
def _reserve_all(
    robots: np.ndarray,
    chosen: np.ndarray,
    here: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
) -> None:
    """Make the reservations of ``robots``' ``chosen`` operations."""
    for r in robots:
        _reserve(r, chosen[r], r, here, cells, heads, heading_moves, at, leaving)


@njit(cache=True, nogil=True)
def _operation_pibt(
    order: np.ndarray,
    priority: np.ndarray,
    fixed: np.ndarray,
    here: np.ndarray,
    ranked: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
    standing: np.ndarray,
    chosen: np.ndarray,
    revisits: int,
    max_kicks: int,
    corner_follows: bool,
) -> None:
    """PIBT over operations (the module's docstring): ``chosen[i]`` (each present robot's
    operation, all waits on entry with their reservations made) is updated in place;
    ``ranked`` (``(N, K)``) lists each robot's operations best first, -1 after the last.
    One root's chain puts robots out at most ``max_kicks`` times (which bounds its
    work), and a robot is placed at most ``revisits`` times a step."""
    n = chosen.shape[0]
    visits, in_chain = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.bool_)
    # The chain: robots, next operation to try, operation before, robot put out (-1).
    stack_robot, stack_next = np.empty(n + 1, np.int64), np.empty(n + 1, np.int64)
    stack_old, stack_put_out = np.empty(n + 1, np.int64), np.empty(n + 1, np.int64)
    for root in order:
        if visits[root] > 0 or fixed[root]:
            continue
        old = chosen[root]
        _reserve(root, old, -1, here, cells, heads, heading_moves, at, leaving)
        top, kicks = 0, 0
        stack_robot[0], stack_next[0], stack_old[0], stack_put_out[0] = root, 0, old, -1
        in_chain[root] = True
        accepted = False
        while top >= 0:
            r = stack_robot[top]
            if stack_put_out[top] >= 0:  # the robot put out found nothing: give it back
                other = stack_put_out[top]
                _reserve(r, chosen[r], -1, here, cells, heads, heading_moves, at, leaving)
                _reserve(other, chosen[other], other, here, cells, heads, heading_moves, at,
                         leaving)  # fmt: skip
                stack_put_out[top] = -1
            pushed = False
            while stack_next[top] < ranked.shape[1] and ranked[r, stack_next[top]] >= 0:
                k = ranked[r, stack_next[top]]
                stack_next[top] += 1
                other = _conflict(r, k, here, cells, heads, heading_moves, at, leaving,
                                  standing, corner_follows)  # fmt: skip
                if other == -1:
                    chosen[r] = k
                    _reserve(r, k, r, here, cells, heads, heading_moves, at, leaving)
                    accepted = True
                    break
                stuck = other < 0 or fixed[other] or in_chain[other] or kicks >= max_kicks
                if stuck or visits[other] >= revisits or priority[other] >= priority[root]:
                    continue
                kicks += 1
                _reserve(other, chosen[other], -1, here, cells, heads, heading_moves, at,
                         leaving)  # fmt: skip
                chosen[r] = k
                _reserve(r, k, r, here, cells, heads, heading_moves, at, leaving)
                stack_put_out[top] = other
                top += 1
                stack_robot[top], stack_next[top] = other, 0
                stack_old[top], stack_put_out[top] = chosen[other], -1
                in_chain[other] = True
                pushed = True
                break
            if accepted:  # the whole chain stands
                for level in range(top + 1):
                    in_chain[stack_robot[level]] = False
                    visits[stack_robot[level]] += 1
                break
            if pushed:
                continue
            chosen[r] = stack_old[top]  # nothing fits: this robot keeps what it had
            in_chain[r] = False
            top -= 1
        if not accepted:
            _reserve(root, old, root, here, cells, heads, heading_moves, at, leaving)
