"""What every figure of the package is drawn on and with: a :class:`~matplotlib.figure.Figure`
with its own Agg canvas (no pyplot, no window, nothing global), saved atomically as a PNG,
and the small helpers figures share: a rolling mean and a floor's free cells.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from warehouse_phys.files.atomic import atomic_write
from warehouse_phys.world.grid import WarehouseGrid


def rolling_mean(values: np.ndarray, window: int) -> np.ndarray:
    """The mean of the last ``window`` values at each position (of fewer at the start)."""
    if window < 1:
        raise ValueError(f"window must be at least 1, got {window}")
    values = np.asarray(values, dtype=np.float64)
    sums = np.concatenate(([0.0], np.cumsum(values)))
    end = np.arange(1, len(values) + 1)
    start = np.maximum(end - window, 0)
    return (sums[end] - sums[start]) / (end - start)


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A figure with its own Agg canvas: no pyplot, no window, no global state."""
    figure = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def save_figure(figure: Figure, path: str | os.PathLike[str]) -> Path:
    """Save ``figure`` as a PNG, atomically (no half-written file on failure)."""
    return atomic_write(path, lambda file: figure.savefig(file, format="png", dpi=100))


def free_mask(grid: WarehouseGrid) -> np.ndarray:
    """``(rows, cols)`` bool: the cells of ``grid`` that are no shelf."""
    mask = np.ones((grid.rows, grid.cols), dtype=bool)
    if grid.shelves:
        shelves = np.array(sorted(grid.shelves))
        mask[shelves[:, 0], shelves[:, 1]] = False
    return mask
