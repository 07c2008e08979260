"""Guide paths: every robot's, stored, and their searches in batches on as many cores as
asked.

:class:`GuidePaths` stores every robot's guide path in one pool of cells.

:class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance` searches a guide path for each
robot that needs one, priced by the fleet's flow
(:func:`~warehouse_phys.planners.traffic_flow.congestion_path`, compiled and free of
Python's lock). :class:`GuideSearches` runs a *batch* of such searches against one flow:
none of a batch sees the others' paths, which the guidance adds to the flow after the
batch, in order. So a batch's paths depend on the batch alone, not on how many threads
search it: ``workers`` threads split it (robot ``k`` of the batch to thread ``k %
workers``), each with search buffers of its own, and the results are the same for any
number of workers. A batch of one is the sequential search, each path seeing all before
it.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from warehouse_phys.planners import guidance_config, traffic_flow

#: Most threads one :class:`GuideSearches` runs (the guidance's bound).
MAX_WORKERS = guidance_config.MAX_WORKERS


@dataclass
class GuidePaths:
    """Every robot's guide path: robot ``i``'s cells (map columns) are
    ``pool[start[i] : start[i] + moves[i] + 1]``, its goal last, ``moves[i] < 0`` for none;
    ``cursor[i]`` is where along it the robot stands."""

    goal: np.ndarray
    start: np.ndarray
    moves: np.ndarray
    cursor: np.ndarray
    pool: np.ndarray = field(default_factory=lambda: np.empty(1 << 16, dtype=np.int32))
    used: int = 0

    @classmethod
    def empty(cls, n: int) -> GuidePaths:
        none = np.full(n, -1, dtype=np.int64)
        return cls(none.copy(), none.copy(), none.copy(), np.zeros(n, dtype=np.int64))

    def compact(self, needed: int) -> None:
        """Room for ``needed`` more path cells: keep only the live paths' cells from each
        robot's cursor on, and grow the pool if still short."""
        paths = self
        live = np.flatnonzero(paths.moves >= 0)
        left = paths.moves[live] - paths.cursor[live] + 1
        total = int(left.sum()) + len(live)  # each with a cell before it: the cursor's
        capacity = len(paths.pool)
        while capacity < 2 * (total + needed):
            capacity *= 2
        pool = np.empty(capacity, dtype=np.int32)
        starts = 1 + np.concatenate([[0], np.cumsum(left + 1)])[: len(live)].astype(np.int64)
        for i, begin, size in zip(live.tolist(), starts.tolist(), left.tolist(), strict=True):
            first = paths.start[i] + paths.cursor[i]
            pool[begin - 1] = -1  # free again
            pool[begin : begin + size] = paths.pool[first : first + size]
        paths.start[live], paths.moves[live], paths.cursor[live] = starts, left - 1, 0
        paths.pool, paths.used = pool, total


class _Buffers:
    """One thread's search buffers (as
    :func:`~warehouse_phys.planners.traffic_flow.congestion_path` takes them)."""

    def __init__(self, n: int) -> None:
        self.scratch = np.zeros((n, 4), dtype=np.int32)
        self.g_cost = np.zeros(n, dtype=np.float64)
        self.path = np.empty(n, dtype=np.int32)
        self.generation = 0

    def next_generation(self) -> int:
        self.generation += 1
        if self.generation >= 2**31 - 1:  # the stamps wrap: clear them
            self.scratch[:, [0, 3]] = 0
            self.generation = 1
        return self.generation


class GuideSearches:
    """Batches of guide-path searches on one floor's move graph (the module's docstring).

    Args:
        cell_row, cell_col: Each map column's row and column on the floor.
        workers: Threads that search a batch (1: the calling thread alone).

    Raises:
        ValueError: for ``workers`` out of 1..:data:`MAX_WORKERS`.
    """

    def __init__(self, cell_row: np.ndarray, cell_col: np.ndarray, workers: int = 1) -> None:
        if not 1 <= workers <= MAX_WORKERS:
            raise ValueError(f"workers must be in 1..{MAX_WORKERS}, got {workers!r}")
        self.cell_row, self.cell_col = cell_row, cell_col
        self.workers = int(workers)
        # The first thread's buffers now, the others' when a batch first needs them (28
        # bytes a free cell each: 62 MB on a floor of 2.2 million free cells).
        self._buffers: list[_Buffers | None] = [_Buffers(len(cell_row))]
        self._buffers += [None] * (self.workers - 1)
        self._pool: ThreadPoolExecutor | None = None
        self._pool_pid = 0  # the process that started the pool's threads
        #: Cells the last batch's searches expanded, together (the same on any machine
        #: and for any number of workers).
        self.expanded = 0

    def search(
        self,
        graph: np.ndarray,
        flow: np.ndarray,
        lanes: np.ndarray,
        sources: list[int],
        goals: list[int],
        facings: list[int],
        costs: np.ndarray,
    ) -> list[np.ndarray | None]:
        """The guide path (map columns, source first, goal last) of each search of the
        batch, ``None`` where the goal cannot be reached; every search against ``flow``
        and ``lanes`` as they are now (neither is written). :attr:`expanded` becomes the
        cells the batch's searches expanded, together."""
        found: list[np.ndarray | None] = [None] * len(sources)
        expanded = [0] * len(sources)

        def run(worker: int) -> None:
            buffers = self._buffers[worker]
            if buffers is None:  # this thread's alone to write
                buffers = self._buffers[worker] = _Buffers(len(self.cell_row))
            for k in range(worker, len(sources), self.workers):
                moves, expanded[k] = traffic_flow.congestion_path(
                    graph, self.cell_row, self.cell_col, flow, lanes, sources[k], goals[k],
                    costs, buffers.scratch, buffers.g_cost, buffers.next_generation(),
                    buffers.path, facings[k])  # fmt: skip
                found[k] = None if moves < 0 else buffers.path[: moves + 1].copy()

        if self.workers == 1 or len(sources) == 1:
            run(0)
        else:
            # A process forked from the one that started the threads has none of them:
            # its pool would wait for ever, so it starts its own.
            if self._pool is None or self._pool_pid != os.getpid():
                self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="guide-search")
                self._pool_pid = os.getpid()
            for future in [self._pool.submit(run, w) for w in range(self.workers)]:
                future.result()
        self.expanded = sum(expanded)
        return found

    def __getstate__(self) -> dict[str, object]:
        """What a pickle keeps: everything but the threads and their buffers (the next
        batch starts them)."""
        buffers = [self._buffers[0]] + [None] * (self.workers - 1)
        return {**self.__dict__, "_pool": None, "_pool_pid": 0, "_buffers": buffers}

    def close(self) -> None:
        """Stop the threads and free their buffers (a later batch starts them again)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        self._buffers[1:] = [None] * (self.workers - 1)
