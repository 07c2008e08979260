"""Lanes learned from the fleet's own traffic: direction costs for every cell of a floor.

The guidance's one-way lanes (:mod:`warehouse_phys.planners.lanes`) follow a rule of the
floor's shape, the same whatever the robots do. :class:`TrafficLanes` learns them from the
traffic instead, online, in the spirit of Zang et al.'s online guidance graph
optimisation (AAAI 2025): it counts the moves robots make out of every cell each way,
forgetting old ones (a decay each step), and every ``period`` steps lays phantom guide
paths (:attr:`TrafficLanes.paths` of them) along the way that carries at least ``share`` of
a cell's traffic along its axis, where the cell saw at least ``minimum`` moves along it.
So where robots mostly go one way the guide paths of those that would go the other way
pay its contraflow, and they take a neighbouring row or column; where traffic is balanced
or thin, nothing changes. What it learns is the fleet's, on the floor it runs on:
:meth:`TrafficLanes.save` writes it beside the floor's digest and :meth:`TrafficLanes.load`
starts another run of any instance on that floor from it.

Deterministic: the same moves give the same lanes. Like :mod:`warehouse_phys.world.grid`,
this module imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from warehouse_phys.files.atomic import atomic_write


def floor_digest(free: np.ndarray) -> str:
    """A digest of a floor's free cells (its shape and which cells are free)."""
    free = np.ascontiguousarray(np.asarray(free, dtype=bool))
    return hashlib.sha256(repr(free.shape).encode() + np.packbits(free).tobytes()).hexdigest()


class TrafficLanes:
    """One-way lanes learned from the moves robots make (the module's docstring).

    Args:
        graph: The floor's move graph (``(n, 4)``: each map column's neighbour by move,
            -1 for none; :func:`~warehouse_phys.planners.graph_search.move_graph`).
        paths: Phantom guide paths a learned lane carries (>= 1).
        period: Steps between two updates of the lanes (>= 1).
        decay: What is left of a count after a step (0 < decay <= 1).
        share: The share of a cell's moves along an axis its lane must carry (0.5..1).
        minimum: Fewest moves along the axis (decayed) before a cell gets a lane (> 0).

    Raises:
        ValueError: for a setting out of its range.
    """

    def __init__(
        self,
        graph: np.ndarray,
        *,
        paths: int = 2,
        period: int = 50,
        decay: float = 0.995,
        share: float = 0.7,
        minimum: float = 4.0,
    ) -> None:
        if paths < 1 or period < 1 or not 0 < decay <= 1 or not 0.5 <= share <= 1 or minimum <= 0:
            raise ValueError(
                "paths and period must be >= 1, decay in (0, 1], share in [0.5, 1] and minimum "
                f"> 0, got {paths!r}, {period!r}, {decay!r}, {share!r}, {minimum!r}"
            )
        self.graph = graph
        self.paths, self.period, self.decay = int(paths), int(period), float(decay)
        self.share, self.minimum = float(share), float(minimum)
        #: Moves robots made out of each cell by each move, decayed [moves].
        self.counts = np.zeros((len(graph), 4), dtype=np.float64)
        self.steps = 0
        self._previous: np.ndarray | None = None

    def observe(self, column: np.ndarray) -> bool:
        """Count the moves robots made since the last call (``column``: each robot's map
        column now, -1 off the floor); True when the lanes are due again (every
        ``period`` calls)."""
        column = np.asarray(column, dtype=np.int64)
        self.counts *= self.decay
        if self._previous is not None and len(self._previous) == len(column):
            before = self._previous
            moved = (before >= 0) & (column >= 0) & (before != column)
            came, went = before[moved], column[moved]
            step = self.graph[came] == went[:, None]
            made = step.any(axis=1)
            np.add.at(self.counts, (came[made], step[made].argmax(axis=1)), 1.0)
        self._previous = column.copy()
        self.steps += 1
        return self.steps % self.period == 0

    def lanes(self) -> np.ndarray:
        """``(n, 4)`` int32: :attr:`paths` phantom guide paths along each cell's learned
        lanes (the module's docstring), 0 elsewhere."""
        lanes = np.zeros(self.counts.shape, dtype=np.int32)
        for move in range(4):
            along, against = self.counts[:, move], self.counts[:, (move + 2) % 4]
            total = along + against
            lanes[(total >= self.minimum) & (along >= self.share * total), move] = self.paths
        return lanes

    def save(self, path: str | os.PathLike[str], free: np.ndarray) -> Path:
        """Write the counts, with the digest of the floor ``free`` they were learned on."""
        digest = floor_digest(free)
        return atomic_write(path, lambda file: np.savez(file, counts=self.counts, digest=digest))

    def load(self, path: str | os.PathLike[str], free: np.ndarray) -> None:
        """Start from the counts saved at ``path``.

        Raises:
            ValueError: if the file cannot be read or was learned on another floor.
        """
        try:
            with np.load(path, allow_pickle=False) as saved:
                counts, digest = saved["counts"], str(saved["digest"])
        except (OSError, ValueError, KeyError) as error:
            raise ValueError(f"{path}: not learned lanes ({error})") from None
        if digest != floor_digest(free) or counts.shape != self.counts.shape:
            raise ValueError(f"{path}: lanes learned on another floor")
        self.counts = counts.astype(np.float64)
