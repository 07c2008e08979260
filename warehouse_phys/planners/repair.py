"""Windowed repair: a large-neighbourhood search over the next few steps of a turning
fleet's plan.

PIBT (one step) and PIBT over operations (:mod:`warehouse_phys.planners.operations`, a few
steps) settle each meeting greedily, in priority order: a robot that came first keeps a
cell that a robot behind it needed more, and the robot behind waits. After Li et al.'s
MAPF-LNS and its windowed use in Jiang et al.'s WPPL (windowed parallel PIBT-LNS), the
repair takes the fleet's plan over a window of ``depth`` steps in ``(cell, heading)``
space-time, every robot holding one *operation* (``depth`` turning actions, its cells and
moves reserved at each step, :func:`~warehouse_phys.planners.operations.operation_table`),
and improves it:

- A *seed* is a robot whose operation is worth less than its best (a robot delayed by
  others), taken in an order drawn from the seed of the repair.
- Its *neighbourhood* is grown from it: the robots holding the reservations that its
  better operations meet, then theirs, up to ``neighbourhood`` robots (none that is
  parked).
- The neighbourhood's operations are taken off and planned again, one robot after
  another (the seed first), each taking its best operation that meets no reservation
  left; the new operations are kept only if the neighbourhood's values sum to less than
  before (each operation's value: its steps to the goal, or ``depth`` plus where it
  leaves the robot, as the operations' module values them), else the old ones are put
  back.

So the repair never makes the plan worse by its measure, and never less safe: every
operation it keeps meets no other robot's reservation at any step of the window, and the
planner passes the first actions through the traffic rule after (a refusal there, which
the reservations rule out, would put the whole plan back as it was). Its work is bounded
by ``iterations`` neighbourhoods a step and, optionally, ``time_limit`` seconds or an
instant (:attr:`WindowRepair.deadline`, a planner's bound on its whole step), both checked
between rounds of :data:`ROUND` neighbourhoods (a run that reaches either may differ from
another). Deterministic for a seed otherwise.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from warehouse_phys.planners.operation_kernels import _conflict, _reserve

#: Neighbourhoods searched between two looks at the clock.
ROUND = 256
#: A seed's operation must be worth at least this much less than its best [steps].
DELAYED = 0.5


@dataclass
class RepairStats:
    """What the last step's repair did: neighbourhoods tried and kept, the plan's value
    before and after (the sum of its operations' values over the robots planned)."""

    tried: int = 0
    kept: int = 0
    value_before: float = 0.0
    value_after: float = 0.0
    fell_back: bool = False
    #: Its wall time [s].
    seconds: float = 0.0


class WindowRepair:
    """The large-neighbourhood search (the module's docstring) over a plan of operations.

    Args:
        neighbourhood: Most robots planned again together (at least 2).
        iterations: Most neighbourhoods a step (at least 0).
        time_limit: Most seconds a step's repair may take (None: no bound).
        seed: Seeds the order the seeds are taken in.

    Raises:
        ValueError: for a bound out of range.
    """

    def __init__(
        self,
        *,
        neighbourhood: int = 8,
        iterations: int = 2000,
        time_limit: float | None = None,
        seed: int = 0,
    ) -> None:
        if neighbourhood < 2 or iterations < 0 or (time_limit is not None and time_limit < 0):
            raise ValueError(
                "neighbourhood must be >= 2, iterations >= 0 and time_limit >= 0 or None, "
                f"got {neighbourhood!r}, {iterations!r}, {time_limit!r}"
            )
        self.neighbourhood = int(neighbourhood)
        self.iterations = int(iterations)
        self.time_limit = time_limit
        self.rng = np.random.default_rng(seed)
        #: A :func:`time.perf_counter` instant after which no round of neighbourhoods
        #: starts (None: none), besides ``time_limit``: a planner bounding its whole step
        #: sets it before each (:meth:`~warehouse_phys.planners.guidance.GuidedPIBT.plan`).
        self.deadline: float | None = None
        #: The last step's work (:class:`RepairStats`).
        self.stats = RepairStats()

    def extend(
        self,
        robots: np.ndarray,
        first: np.ndarray,
        op_first: np.ndarray,
        here: np.ndarray,
        ranked: np.ndarray,
        cells: np.ndarray,
        heads: np.ndarray,
        heading_moves: np.ndarray,
        at: np.ndarray,
        leaving: np.ndarray,
        standing: np.ndarray,
        chosen: np.ndarray,
        corner_follows: bool,
    ) -> None:
        """The repair's starting plan from a one-step plan: each of ``robots`` in turn
        (their order) takes its best operation that begins with its planned action
        (``first``) and meets no other robot's reservations, in place of its action
        followed by waits; so the robots the search then takes as seeds are those the
        one-step plan delayed, not those it left to wait after their step."""
        _extend(robots, first, op_first, here, ranked, cells, heads, heading_moves, at, leaving,
                standing, chosen, corner_follows)  # fmt: skip

    def improve(
        self,
        movable: np.ndarray,
        here: np.ndarray,
        ranked: np.ndarray,
        values: np.ndarray,
        cells: np.ndarray,
        heads: np.ndarray,
        heading_moves: np.ndarray,
        at: np.ndarray,
        leaving: np.ndarray,
        standing: np.ndarray,
        chosen: np.ndarray,
        corner_follows: bool,
    ) -> None:
        """Improve ``chosen`` (each robot's operation, its reservations made in ``at`` and
        ``leaving``) in place; the arrays are those of
        :class:`~warehouse_phys.planners.operations.OperationPIBT` (``ranked``: each
        robot's valid operations best first, -1 after; ``values``: each operation's
        value)."""
        robots = np.flatnonzero(movable)
        current = values[robots, chosen[robots]]
        best = values[robots, np.maximum(ranked[robots, 0], 0)]
        delayed = robots[current > best + DELAYED]
        seeds = delayed[self.rng.permutation(len(delayed))]
        stats = RepairStats(value_before=float(current.sum()))
        begun = time.perf_counter()
        ends = [t for t in (self.deadline, None if self.time_limit is None
                            else begun + self.time_limit) if t is not None]  # fmt: skip
        deadline = min(ends) if ends else None
        counts = np.zeros(2, dtype=np.int64)
        for first in range(0, min(len(seeds), self.iterations), ROUND):
            if deadline is not None and time.perf_counter() > deadline:
                break
            last = min(first + ROUND, len(seeds), self.iterations)
            _lns(seeds[first:last], ~movable, here, ranked, values, cells, heads,
                 heading_moves, at, leaving, standing, chosen, corner_follows,
                 self.neighbourhood, counts)  # fmt: skip
        stats.tried, stats.kept = int(counts[0]), int(counts[1])
        stats.value_after = float(values[robots, chosen[robots]].sum())
        stats.seconds = time.perf_counter() - begun
        self.stats = stats


@njit(cache=True, nogil=True)
def _extend(
    robots: np.ndarray,
    first: np.ndarray,
    op_first: np.ndarray,
    here: np.ndarray,
    ranked: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
    standing: np.ndarray,
    chosen: np.ndarray,
    corner_follows: bool,
) -> None:
    """Each of ``robots`` in turn takes its best operation that begins with its action
    ``first[r]`` (``op_first``: each operation's first action) and meets no reservation
    left, in place of the one it holds (kept where none does)."""
    for r in robots:
        _reserve(r, chosen[r], -1, here, cells, heads, heading_moves, at, leaving)
        for j in range(ranked.shape[1]):
            k = ranked[r, j]
            if k < 0 or k == chosen[r]:
                break
            if (
                op_first[k] == first[r]
                and _conflict(
                    r, k, here, cells, heads, heading_moves, at, leaving, standing, corner_follows
                )
                == -1
            ):
                chosen[r] = k
                break
        _reserve(r, chosen[r], r, here, cells, heads, heading_moves, at, leaving)


@njit(cache=True, nogil=True)
def _blockers(
    r: int,
    k: int,
    here: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
    found: np.ndarray,
) -> int:
    """The robots whose reservations operation ``k`` of robot ``r`` meets (cells held at
    each step, and moves the other way into its cells), written into ``found``; how many."""
    count = 0
    prev = here[r]
    for d in range(cells.shape[2]):
        cell = cells[r, k, d]
        owner = at[cell, d]
        swap = -1
        if cell != prev:
            swap = leaving[cell * 4 + (heading_moves[heads[r, k, d]] + 2) % 4, d]
        for other in (owner, swap):
            if other >= 0 and other != r and count < found.shape[0]:
                seen = False
                for j in range(count):
                    seen = seen or found[j] == other
                if not seen:
                    found[count] = other
                    count += 1
        prev = cell
    return count


@njit(cache=True, nogil=True)
def _lns(
    seeds: np.ndarray,
    fixed: np.ndarray,
    here: np.ndarray,
    ranked: np.ndarray,
    values: np.ndarray,
    cells: np.ndarray,
    heads: np.ndarray,
    heading_moves: np.ndarray,
    at: np.ndarray,
    leaving: np.ndarray,
    standing: np.ndarray,
    chosen: np.ndarray,
    corner_follows: bool,
    size: int,
    counts: np.ndarray,
) -> None:
    """One round of the repair: a neighbourhood per seed, planned again and kept if its
    operations' values sum to less (the module's docstring). ``counts`` gains the
    neighbourhoods tried and kept."""
    group = np.empty(size, dtype=np.int64)
    old = np.empty(size, dtype=np.int64)
    found = np.empty(3 * cells.shape[2], dtype=np.int64)
    member = np.zeros(chosen.shape[0], dtype=np.bool_)
    for s in seeds:
        if values[s, chosen[s]] <= values[s, ranked[s, 0]] + DELAYED:
            continue  # a neighbourhood before this one already helped it
        members = 1
        group[0] = s
        member[s] = True
        q = 0
        while q < members and members < size:
            r = group[q]
            q += 1
            for j in range(ranked.shape[1]):
                k = ranked[r, j]
                if k < 0 or k == chosen[r] or members >= size:
                    break
                count = _blockers(r, k, here, cells, heads, heading_moves, at, leaving, found)
                for f in range(count):
                    other = found[f]
                    if not member[other] and not fixed[other] and members < size:
                        group[members] = other
                        member[other] = True
                        members += 1
        counts[0] += 1
        before, after = 0.0, 0.0
        for g in range(members):
            r = group[g]
            old[g] = chosen[r]
            before += values[r, chosen[r]]
            _reserve(r, chosen[r], -1, here, cells, heads, heading_moves, at, leaving)
        placed = 0
        for g in range(members):
            r = group[g]
            for j in range(ranked.shape[1]):
                k = ranked[r, j]
                if k < 0:
                    break
                if _conflict(r, k, here, cells, heads, heading_moves, at, leaving, standing,
                             corner_follows) == -1:  # fmt: skip
                    chosen[r] = k
                    _reserve(r, k, r, here, cells, heads, heading_moves, at, leaving)
                    after += values[r, k]
                    placed += 1
                    break
            if placed < g + 1:
                break
        if placed == members and after < before - 1e-9:
            counts[1] += 1
        else:  # put the neighbourhood back as it was
            for g in range(placed):
                r = group[g]
                _reserve(r, chosen[r], -1, here, cells, heads, heading_moves, at, leaving)
            for g in range(members):
                r = group[g]
                chosen[r] = old[g]
                _reserve(r, old[g], r, here, cells, heads, heading_moves, at, leaving)
        for g in range(members):
            member[group[g]] = False
