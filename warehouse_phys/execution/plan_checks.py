"""What a plan must be for the executor to run it, checked with one-line errors: robots'
cells, ticks, gap and headings (:func:`checked_cells`, :func:`checked_ticks`,
:func:`checked_gap`, :func:`checked_headings`), a plan's cells and headings
(:func:`checked_path`), its moves (:func:`check_plan`: from the plan cells, to free
neighbours, no two robots in a cell, no swap, only rotations the robots can make
together) and turning robots' actions (:func:`check_turns`).

With them the array helpers that the executor and its PIBT windows share: "no robot"
(:data:`NO_ROBOT`), and-ing along chains of robots (:func:`and_along`) and cell indices
back to ``(row, col)`` (:func:`rows_cols`).
"""

from __future__ import annotations

import numbers

import numpy as np

from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES
from warehouse_phys.world.traffic import robot_cell_indices

#: "No robot" in the dependency arrays.
NO_ROBOT = -1
#: ``(d_row, d_col)`` of a forward move along each heading (east, south, west, north).
_HEADING_STEP = np.array(ACTION_DELTAS, dtype=np.int64)[HEADING_MOVES]


def and_along(link: np.ndarray, value: np.ndarray) -> np.ndarray:
    """``value[i]`` and-ed with the values down ``i``'s chain of links (round its cycle),
    by pointer doubling: ``link[i] == i`` ends a chain."""
    value = value.copy()
    for _ in range(max(1, len(link)).bit_length()):
        further = link[link]
        value &= value[link]
        if (further == link).all():
            return value
        link = further
    value &= value[link]  # a cycle: 2**bit_length(n) >= n links, round it and beyond
    return value


def check_plan(
    path: np.ndarray,
    start: np.ndarray,
    table: np.ndarray,
    needed: np.ndarray,
    grid: WarehouseGrid,
    min_gap: float,
    *,
    squares: bool = False,
) -> np.ndarray:
    """Refuse a plan (``(N, S + 1)`` cell indices) that does not start from ``start``,
    makes a move that is not one, puts two robots in a cell or across an edge, or has a
    rotation the robots cannot make together (``squares``, the start kit's square robots:
    none); returns ``(S, N)`` bool, the robots that rotate at each step."""
    cols = grid.cols
    wrong = np.flatnonzero(path[:, 0] != start)
    if wrong.size:
        i = int(wrong[0])
        raise ValueError(
            f"path must start from plan_cells(): robot {i} starts at "
            f"{_cell(path[i, 0], cols)}, not {_cell(start[i], cols)}"
        )
    n, steps = path.shape[0], path.shape[1] - 1
    if not steps or not n:
        return np.zeros((steps, n), dtype=bool)
    step_ok = (table[path[:, :-1]] == path[:, 1:, None]).any(axis=2)
    if not step_ok.all():
        i, s = (int(v[0]) for v in np.nonzero(~step_ok))
        raise ValueError(
            f"path moves robot {i} from {_cell(path[i, s], cols)} to "
            f"{_cell(path[i, s + 1], cols)} at step {s + 1}: not a move to a free neighbour"
        )
    by_step = np.sort(path, axis=0)
    shared = np.nonzero(by_step[1:] == by_step[:-1])
    if shared[0].size:
        s = int(shared[1][0])
        cell = by_step[shared[0][0], s]
        both = np.flatnonzero(path[:, s] == cell)[:2].tolist()
        raise ValueError(f"path puts robots {both} on {_cell(cell, cols)} at step {s}")
    return _check_follows(path, needed, cols, min_gap, squares)


def _check_follows(
    path: np.ndarray, needed: np.ndarray, cols: int, min_gap: float, squares: bool
) -> np.ndarray:
    """Refuse swaps, and rotations of robots whose moves take different ticks or that
    could not pass each other round the rotation's corners with ``min_gap`` (square
    robots: any rotation); returns ``(S, N)`` bool, the robots that rotate at each step."""
    n, steps = path.shape[0], path.shape[1] - 1
    # Who stands on each cell at each step: (step, cell) keys sorted, looked up.
    keys = (np.arange(steps + 1)[None, :] * (path.max() + 1) + path).T.ravel()
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    s_all = np.repeat(np.arange(steps), n)
    before, after = path[:, :-1].T.ravel(), path[:, 1:].T.ravel()
    enter = s_all * (path.max() + 1) + after  # the entered cell, one step earlier
    spot = np.minimum(np.searchsorted(sorted_keys, enter), len(keys) - 1)
    found = (sorted_keys[spot] == enter) & (before != after)
    occupant = np.where(found, order[spot] % n, -1)  # robot there before the step
    node = np.arange(n * steps)
    follows = found & (occupant != node % n)
    leader = np.where(follows, s_all * n + occupant, node)
    swap = follows & (after[leader] == before)
    if swap.any():
        x = int(np.flatnonzero(swap)[0])
        pair = sorted((x % n, int(occupant[x])))
        raise ValueError(f"path swaps robots {pair} at step {x // n + 1}")
    rotating = and_along(leader, follows)  # every robot down its chain follows: a cycle
    mixed = rotating & ((needed[node % n] != needed[leader % n]) | (min_gap > DEFAULT_MIN_GAP))
    if squares and rotating.any():
        x = int(np.flatnonzero(rotating)[0])
        raise ValueError(
            f"path rotates robot {x % n} round a cycle at step {x // n + 1}: square robots "
            "(agent_size) never rotate, the start kit's squares would collide; plan without "
            "rotations (pibt_window(..., rotations=False))"
        )
    if mixed.any():
        x = int(np.flatnonzero(mixed)[0])
        raise ValueError(
            f"path rotates robot {x % n} (ticks_needed {int(needed[x % n])}, min_gap "
            f"{min_gap:.3g}) round a cycle at step {x // n + 1}: only robots whose moves take "
            "the same ticks, with min_gap at most sqrt(1/2), can rotate; plan without "
            "rotations (pibt_window(..., rotations=False))"
        )
    return rotating.reshape(steps, n)


def checked_cells(grid: WarehouseGrid, cells: np.ndarray) -> np.ndarray:
    """Distinct free cells as cell indices, or a one-line ``ValueError`` naming ``cells``."""
    here = robot_cell_indices(grid, cells, prefix="cells: ")
    shelf = ~grid.free_mask.reshape(-1)[here]
    if shelf.any():
        i = int(np.flatnonzero(shelf)[0])
        raise ValueError(f"cells: robot {i}'s cell {divmod(int(here[i]), grid.cols)} is a shelf")
    return here


def checked_ticks(ticks_needed: np.ndarray | int, n: int) -> np.ndarray:
    """``(N,)`` int64 ticks of at least 1, or a one-line error naming ``ticks_needed``."""
    ticks = np.asarray(ticks_needed)
    if ticks.dtype.kind not in "iu":
        raise TypeError(f"ticks_needed must be integers, got {ticks.dtype}")
    if ticks.ndim == 0:
        ticks = np.full(n, int(ticks), dtype=np.int64)
    if ticks.shape != (n,):
        raise ValueError(
            f"ticks_needed must be one integer or one per robot ({n}), got {ticks.shape}"
        )
    if (ticks < 1).any():
        i = int(np.flatnonzero(ticks < 1)[0])
        raise ValueError(f"ticks_needed must be at least 1, got {int(ticks[i])} for robot {i}")
    return ticks.astype(np.int64)


def checked_path(
    grid: WarehouseGrid, path: np.ndarray, n: int, turning: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """``(N, S + 1)`` cell indices of a plan's ``(row, col)`` cells on the floor, and the
    turning robots' ``(N, S + 1)`` headings (``None`` for four-direction robots)."""
    path = np.asarray(path)
    width = 3 if turning else 2
    if path.ndim != 3 or path.shape[0] != n or path.shape[1] < 1 or path.shape[2] != width:
        what = "(row, col, heading)" if turning else "(row, col)"
        raise ValueError(f"path must be (N={n}, steps + 1, {width}) {what}, got shape {path.shape}")
    if path.dtype.kind not in "iu":
        raise ValueError(f"path must hold integer cells, got {path.dtype}")
    rows, cols = path[..., 0].astype(np.int64), path[..., 1].astype(np.int64)
    off = (rows < 0) | (rows >= grid.rows) | (cols < 0) | (cols >= grid.cols)
    if off.any():
        i, s = (int(v[0]) for v in np.nonzero(off))
        raise ValueError(f"path puts robot {i} off the floor at step {s}")
    faces = path[..., 2].astype(np.int64) if turning else None
    if faces is not None and ((faces < 0) | (faces > 3)).any():
        i, s = (int(v[0]) for v in np.nonzero((faces < 0) | (faces > 3)))
        raise ValueError(f"path gives robot {i} heading {faces[i, s]} at step {s}, not 0..3")
    return rows * grid.cols + cols, faces


def check_turns(path: np.ndarray, faces: np.ndarray, facing: np.ndarray, cols: int) -> None:
    """Refuse turning robots' plans that do not start facing ``facing``, move other than
    forward along the heading, or turn other than a quarter turn in place."""
    wrong = np.flatnonzero(faces[:, 0] != facing)
    if wrong.size:
        i = int(wrong[0])
        raise ValueError(f"path must start from plan_headings(): robot {i} faces "
                         f"{faces[i, 0]}, not {facing[i]}")  # fmt: skip
    moved = path[:, 1:] != path[:, :-1]
    turn = (faces[:, 1:] - faces[:, :-1]) % 4
    ahead = _HEADING_STEP[faces[:, :-1]]  # (N, S) cell offsets of a forward move
    step = path[:, 1:] - path[:, :-1]
    bad = (moved & ((turn != 0) | (step != ahead[..., 0] * cols + ahead[..., 1]))) | (
        ~moved & (turn == 2)
    )
    if bad.any():
        i, s = (int(v[0]) for v in np.nonzero(bad))
        raise ValueError(
            f"path takes robot {i} from {_cell(path[i, s], cols)} facing {faces[i, s]} to "
            f"{_cell(path[i, s + 1], cols)} facing {faces[i, s + 1]} at step {s + 1}: not a "
            "forward move along its heading or a quarter turn in place"
        )


def checked_gap(min_gap: object) -> float:
    """``min_gap`` as a float in ``(0, 1]``, or a one-line error naming it."""
    if isinstance(min_gap, (bool, np.bool_)) or not isinstance(min_gap, numbers.Real):
        raise TypeError(f"min_gap must be a real number of cells, got {min_gap!r}")
    gap = float(min_gap)
    if not 0 < gap <= 1:
        raise ValueError(f"min_gap must be in (0, 1] cells, got {min_gap!r}")
    return gap


def checked_headings(headings: np.ndarray, n: int) -> np.ndarray:
    """``(N,)`` int64 headings 0..3, or a one-line error naming ``headings``."""
    heads = np.asarray(headings)
    if heads.shape != (n,) or heads.dtype.kind not in "iu" or ((heads < 0) | (heads > 3)).any():
        raise ValueError(f"headings must be ({n},) integers 0..3, got {heads.dtype} {heads.shape}")
    return heads.astype(np.int64)


def checked_delayed(delayed: np.ndarray, n: int) -> np.ndarray:
    delayed = np.asarray(delayed)
    if delayed.shape != (n,) or delayed.dtype != bool:
        raise ValueError(f"delayed must be ({n},) bool, got {delayed.dtype} {delayed.shape}")
    return delayed


def rows_cols(cells: np.ndarray, cols: int) -> np.ndarray:
    """``(..., 2)`` the ``(row, col)`` of cell indices ``cells`` on a floor of ``cols``
    columns."""
    return np.stack(np.divmod(cells, cols), axis=-1)


def _cell(index: int, cols: int) -> tuple[int, int]:
    return divmod(int(index), cols)
