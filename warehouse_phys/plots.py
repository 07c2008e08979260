"""Learning-curve pictures, drawn with matplotlib's object API (no pyplot, no window)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from warehouse_phys.atomic import atomic_write
from warehouse_phys.qlearning import TrainingResult

#: Episodes averaged in the rolling mean of the learning curve.
ROLLING_WINDOW = 100


def rolling_mean(values: np.ndarray, window: int) -> np.ndarray:
    """The mean of the last ``window`` values at each position (of fewer at the start)."""
    if window < 1:
        raise ValueError(f"window must be at least 1, got {window}")
    values = np.asarray(values, dtype=np.float64)
    sums = np.concatenate(([0.0], np.cumsum(values)))
    end = np.arange(1, len(values) + 1)
    start = np.maximum(end - window, 0)
    return (sums[end] - sums[start]) / (end - start)


def learning_curve_figure(result: TrainingResult, title: str = "") -> Figure:
    """Two panels: the rolling mean of steps per episode, and the success of each episode.

    Success is reaching the target before the time limit; the second panel
    shows each episode as a dot (1 reached, 0 truncated) and the rolling
    success rate over the same window.
    """
    episodes = np.arange(1, len(result.steps) + 1)
    window = min(ROLLING_WINDOW, len(episodes))
    figure = Figure(figsize=(8, 5.5), layout="constrained")
    FigureCanvasAgg(figure)
    steps_axes, success_axes = figure.subplots(2, 1, sharex=True)

    steps_axes.plot(episodes, result.steps, color="0.8", linewidth=0.8, label="steps")
    steps_axes.plot(
        episodes, rolling_mean(result.steps, window), color="C0", label=f"mean of {window}"
    )
    steps_axes.set_ylabel("steps per episode")
    steps_axes.set_yscale("log")
    steps_axes.legend(loc="upper right")
    steps_axes.grid(alpha=0.3)

    success = result.reached_target.astype(np.float64)
    success_axes.scatter(episodes, success, s=4, color="C2", alpha=0.4, label="episode")
    success_axes.plot(
        episodes, rolling_mean(success, window), color="C1", label=f"rate over {window}"
    )
    success_axes.set_ylim(-0.05, 1.05)
    success_axes.set_ylabel("reached the target")
    success_axes.set_xlabel("episode")
    success_axes.legend(loc="lower right")
    success_axes.grid(alpha=0.3)
    if title:
        figure.suptitle(title)
    return figure


def save_figure(figure: Figure, path: str | os.PathLike[str]) -> Path:
    """Save ``figure`` as a PNG, atomically (no half-written file on failure)."""
    return atomic_write(path, lambda file: figure.savefig(file, format="png", dpi=100))
