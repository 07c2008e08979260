"""Pictures of training, policies and motion, drawn with matplotlib's object API.

Every function returns a :class:`matplotlib.figure.Figure` with its own Agg
canvas: no pyplot, no window, nothing global. Save one with
:func:`save_figure`; in a notebook it shows inline after ``%matplotlib inline``.

The canvas and the helpers every figure shares are :mod:`warehouse_phys.viz.figures`; the
figures of lifelong fleet runs (throughput, congestion, planners' scaling) are
:mod:`warehouse_phys.viz.throughput_figures`. Their names still import from here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.rl.greedy_policy import greedy_actions, state_values
from warehouse_phys.rl.qlearning import TrainingResult

# The canvas and the fleet runs' figures live in modules of their own; re-exported here,
# where they lived first (see __all__).
from warehouse_phys.viz.figures import free_mask, new_figure, rolling_mean, save_figure
from warehouse_phys.viz.throughput_figures import (
    PLANNER_LABELS,
    TITLE_SHARE,
    TITLE_WIDTH,
    congestion_figure,
    planner_scaling_figure,
    throughput_by_robots_figure,
    throughput_figure,
)
from warehouse_phys.world.grid import WarehouseGrid

if TYPE_CHECKING:
    from warehouse_phys.rl.fleet_learning import FleetEvaluation

#: Episodes averaged in the rolling mean of the learning curve.
ROLLING_WINDOW = 100


def learning_curve_figure(result: TrainingResult, title: str = "") -> Figure:
    """Two panels: the rolling mean of steps per episode, and the success of each episode.

    Success is reaching the target before the time limit; the second panel
    shows each episode as a dot (1 reached, 0 truncated) and the rolling
    success rate over the same window.
    """
    figure = new_figure(figsize=(8, 5.5))
    steps_axes, success_axes = figure.subplots(2, 1, sharex=True)
    _draw_learning_curve(result, steps_axes, success_axes)
    if title:
        figure.suptitle(title)
    return figure


def learning_curves_figure(results: Mapping[str, TrainingResult], title: str = "") -> Figure:
    """:func:`learning_curve_figure`'s two panels for each result, side by side.

    ``results`` maps a column title (``"grid twin"``, say) to a training result;
    the columns share their axes, so the curves compare at a glance.
    """
    if not results:
        raise ValueError("results is empty: nothing to plot")
    figure = new_figure(figsize=(4.5 * len(results), 5.5))
    axes = figure.subplots(2, len(results), sharex=True, sharey="row", squeeze=False)
    for column, (name, result) in enumerate(results.items()):
        _draw_learning_curve(result, axes[0, column], axes[1, column])
        axes[0, column].set_title(name)
        if column:
            axes[0, column].set_ylabel("")
            axes[1, column].set_ylabel("")
    if title:
        figure.suptitle(title)
    return figure


def _draw_learning_curve(result: TrainingResult, steps_axes: Axes, success_axes: Axes) -> None:
    episodes = np.arange(1, len(result.steps) + 1)
    window = min(ROLLING_WINDOW, len(episodes))
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


# ------------------------------------------------------------- frames and paths
def frame_strips_figure(
    strips: Mapping[str, Sequence[np.ndarray]],
    captions: Mapping[str, Sequence[str]] | None = None,
    *,
    frame_inches: float = 1.6,
) -> Figure:
    """Rows of rendered frames: one row per entry of ``strips``, titled with its key.

    Args:
        strips: Row title to ``(H, W, 3)`` frames, left to right.
        captions: Row title to one caption per frame (optional).
        frame_inches: Width of one frame in the figure [in].
    """
    if not strips or not all(len(frames) for frames in strips.values()):
        raise ValueError("every strip needs at least one frame")
    captions = captions or {}
    columns = max(len(frames) for frames in strips.values())
    height, width = np.shape(next(iter(strips.values()))[0])[:2]
    figure = new_figure(
        figsize=(frame_inches * columns, (frame_inches * height / width + 0.35) * len(strips))
    )
    axes = figure.subplots(len(strips), columns, squeeze=False)
    for row, (name, frames) in enumerate(strips.items()):
        labels = captions.get(name, ())
        for column, ax in enumerate(axes[row]):
            ax.set_axis_off()
            if column >= len(frames):
                continue
            ax.imshow(frames[column], interpolation="antialiased")
            if column < len(labels):
                ax.set_title(labels[column], fontsize=8)
        axes[row, 0].text(
            -0.08, 0.5, name, transform=axes[row, 0].transAxes, rotation=90,
            ha="right", va="center", fontsize=10,
        )  # fmt: skip
    return figure


def path_figure(
    grid: WarehouseGrid,
    cells: np.ndarray,
    target: tuple[int, int],
    path: np.ndarray | None = None,
    title: str = "",
) -> Figure:
    """The floor from above, the discrete cell sequence and, if given, the body's path.

    Args:
        grid: The floor (its size and shelves).
        cells: ``(n + 1, 2)`` the robot's cell after the reset and after each step.
        target: The package's cell.
        path: ``(k, 2)`` the body's positions in cell units (one per physics step).
        title: The figure's title.
    """
    figure = new_figure(figsize=(1.0 * grid.cols + 1.5, 1.0 * grid.rows + 0.8))
    ax = figure.subplots()
    _draw_floor(ax, grid, target)
    cells = np.asarray(cells, dtype=np.float64)
    ax.plot(
        cells[:, 1], cells[:, 0], "s--", color="C0", markersize=9, markerfacecolor="none",
        linewidth=1, label="cells (grid twin)",
    )  # fmt: skip
    if path is not None:
        path = np.asarray(path, dtype=np.float64)
        ax.plot(
            path[:, 1], path[:, 0], ".-", color="C3", markersize=2.5, linewidth=0.8,
            label="body, every physics step",
        )  # fmt: skip
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.02), ncol=2, fontsize=8, frameon=False)
    if title:
        ax.set_title(title)
    return figure


def speed_profile_figure(
    times: np.ndarray, speeds: np.ndarray, config: PhysicsConfig, title: str = ""
) -> Figure:
    """The body's speed over one move, with the controller's speed limit and the settle phase."""
    figure = new_figure(figsize=(6.5, 3.2))
    ax = figure.subplots()
    settle_from = config.move_duration - config.settle_time
    ax.axvspan(settle_from, config.move_duration, color="0.92", label="settle phase")
    ax.axhline(config.max_speed, color="0.5", linestyle=":", label="speed limit")
    ax.plot(times, speeds, "o-", color="C3", markersize=3, label="body speed")
    ax.set_xlim(0, config.move_duration)
    ax.set_ylim(0, config.max_speed * 1.15)
    ax.set_xlabel("time since the action [s]")
    ax.set_ylabel("speed [m/s]")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    if title:
        ax.set_title(title)
    return figure


def snap_error_figure(errors: np.ndarray, bound: float, title: str = "") -> Figure:
    """A histogram of pre-snap errors [cells] against the bound the environment promises."""
    errors = np.asarray(errors, dtype=np.float64)
    if errors.size == 0:
        raise ValueError("no snap errors to plot")
    figure, ax = _histogram_figure(
        errors,
        np.linspace(0, bound, 81),
        [
            (bound, {"color": "C3", "linestyle": "--", "label": f"bound {bound:g}"}),
            (errors.max(), {"color": "C1", "label": f"largest {errors.max():.4f}"}),
        ],
        xlabel="distance from the cell centre before the snap [cells]",
        ylabel="moves",
        title=title or f"{errors.size} moves",
    )
    ax.set_xlim(0, bound * 1.05)
    return figure


def fleet_gap_figure(gaps: np.ndarray, config: PhysicsConfig, title: str = "") -> Figure:
    """A histogram of how close robots' discs came to each other [cells] (``min_gap``, the
    closest approach of each robot to the robots within reach; ``inf`` values are left
    out): 0 is touching; the line marks a corner follow's gap, the closest the traffic
    rule allows."""
    from warehouse_phys.physics import COLLISION_SLOP
    from warehouse_phys.world.traffic import CORNER_FOLLOW_DISTANCE

    gaps = np.asarray(gaps, dtype=np.float64)
    gaps = gaps[np.isfinite(gaps)]
    if gaps.size == 0:
        raise ValueError("no gaps to plot")
    diameter = 2 * config.robot_radius / config.cell_size
    corner = CORNER_FOLLOW_DISTANCE - diameter
    figure, _ = _histogram_figure(
        gaps,
        np.linspace(-COLLISION_SLOP, max(gaps.max(), 1.5), 81),
        [
            (0.0, {"color": "C3", "linestyle": "--", "label": "discs touching"}),
            (corner, {"color": "C2", "linestyle": ":", "label": f"corner follow {corner:.3f}"}),
            (gaps.min(), {"color": "C1", "label": f"closest {gaps.min():.3f}"}),
        ],
        xlabel="smallest gap to a robot within reach during a step [cells]",
        ylabel="robot-steps",
        title=title or f"{gaps.size} robot-steps",
    )
    return figure


def fleet_delay_figure(evaluations: Mapping[str, FleetEvaluation], title: str = "") -> Figure:
    """For each policy, the delivering robots' steps beside their shortest paths, and the
    packages left undelivered: what traffic costs."""
    if not evaluations:
        raise ValueError("evaluations is empty: nothing to plot")
    names = list(evaluations)
    figure = new_figure(figsize=(7.5, 3.2))
    steps_ax, missed_ax = figure.subplots(1, 2)
    x = np.arange(len(names))
    shortest = [evaluations[n].shortest_steps for n in names]
    taken = [evaluations[n].robot_steps for n in names]
    steps_ax.bar(x - 0.2, shortest, 0.4, label="shortest paths", color="C2")
    steps_ax.bar(x + 0.2, taken, 0.4, label="steps taken", color="C0")
    steps_ax.set_xticks(x, names)
    steps_ax.set_ylabel("robot-steps of the delivered packages")
    steps_ax.legend(fontsize=8)
    missed = [evaluations[n].episodes * evaluations[n].robots - evaluations[n].delivered
              for n in names]  # fmt: skip
    missed_ax.bar(x, missed, 0.5, color="C3")
    missed_ax.set_xticks(x, names)
    missed_ax.set_ylabel("packages not delivered")
    for ax in (steps_ax, missed_ax):
        ax.grid(alpha=0.3, axis="y")
    if title:
        figure.suptitle(title)
    return figure


# --------------------------------------------------------- policies and values
#: Arrow directions (d_col, d_row) on screen for LEFT, DOWN, RIGHT, UP.
_ARROWS = np.array([(-1, 0), (0, 1), (1, 0), (0, -1)], dtype=np.float64)


def policy_figure(q: np.ndarray, grid: WarehouseGrid, target: tuple[int, int]) -> Figure:
    """Two panels for one target: the greedy action of each cell as an arrow, and its value.

    Cells whose values were never updated (unvisited, shelves, the target) get
    no arrow. The value is ``max_a Q``, printed in each floor cell but the target's.
    """
    actions = greedy_actions(q, target)
    values = state_values(q, target)
    figure = new_figure(figsize=(2 * (0.9 * grid.cols + 0.8), 0.9 * grid.rows + 0.9))
    policy_ax, value_ax = figure.subplots(1, 2)

    _draw_floor(policy_ax, grid, target)
    rows, cols = np.nonzero(actions >= 0)
    arrows = _ARROWS[actions[rows, cols]]
    policy_ax.quiver(
        cols - 0.3 * arrows[:, 0], rows - 0.3 * arrows[:, 1], arrows[:, 0], arrows[:, 1],
        angles="xy", scale_units="xy", scale=1 / 0.6, color="C0", width=0.012,
    )  # fmt: skip
    policy_ax.set_title("greedy action")

    # Shelves and the target (where an episode ends, so never updated) have no value to show.
    hidden = ~free_mask(grid)
    hidden[target[0], target[1]] = True
    shown = np.ma.masked_array(values, mask=hidden)
    image = value_ax.imshow(shown, cmap="viridis", vmin=0, vmax=max(1.0, float(values.max())))
    for (r, c), value in np.ndenumerate(values):
        if not hidden[r, c]:
            colour = "white" if value < 0.6 else "black"
            value_ax.text(c, r, f"{value:.2f}", ha="center", va="center", fontsize=8, color=colour)
    value_ax.text(target[1], target[0], "target", ha="center", va="center", fontsize=8)
    value_ax.set_xticks(range(grid.cols))
    value_ax.set_yticks(range(grid.rows))
    value_ax.set_title("value: max over actions of Q")
    figure.colorbar(image, ax=value_ax, shrink=0.8)
    return figure


def sweep_figure(
    configurations: Mapping[str, Sequence[Mapping[str, object]]], title: str = ""
) -> Figure:
    """A sweep at a glance: for each configuration (its seeds' results), the fraction of
    targets reached by a shortest path, seed by seed, and the learning curves' mean
    with the band from the lowest to the highest seed.

    Args:
        configurations: Label -> one mapping per finished seed, each with
            ``"fraction_optimal"`` and ``"learning_curve"`` (``{"episodes": [...],
            "mean_steps": [...]}``, as in a run's ``summary.json``).
        title: The figure's title.
    """
    labels = list(configurations)
    figure = new_figure((12, 2.4 + 0.4 * max(len(labels), 3)))
    optimal_axes, curve_axes = figure.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.4]})
    colours = [f"C{i % 10}" for i in range(len(labels))]
    for row, (label, colour) in enumerate(zip(labels, colours, strict=True)):
        runs = configurations[label]
        fractions = [float(run["fraction_optimal"]) for run in runs]
        if fractions:
            optimal_axes.scatter(fractions, [row] * len(fractions), color=colour, alpha=0.7, s=18)
            optimal_axes.plot([np.mean(fractions)] * 2, [row - 0.3, row + 0.3], color=colour)
        curves = [run["learning_curve"] for run in runs]
        lengths = {len(curve["episodes"]) for curve in curves}
        if len(lengths) == 1 and lengths != {0}:
            episodes = np.asarray(curves[0]["episodes"])
            steps = np.array([curve["mean_steps"] for curve in curves], dtype=float)
            curve_axes.plot(episodes, steps.mean(axis=0), color=colour, label=label)
            curve_axes.fill_between(
                episodes, steps.min(axis=0), steps.max(axis=0), color=colour, alpha=0.2
            )
    optimal_axes.set_yticks(range(len(labels)), labels, fontsize=8)
    optimal_axes.set_ylim(len(labels) - 0.5, -0.5)
    optimal_axes.set_xlim(-0.05, 1.05)
    optimal_axes.set_xlabel("share of targets reached by a shortest path\n(dot: a seed, bar: mean)")
    optimal_axes.grid(axis="x", alpha=0.3)
    curve_axes.set_xlabel("episode")
    curve_axes.set_ylabel("steps per episode\n(rolling mean)")
    curve_axes.set_yscale("log")
    curve_axes.grid(alpha=0.3)
    if curve_axes.get_legend_handles_labels()[0]:  # no curve (every trial failed): no legend
        curve_axes.legend(fontsize=7, loc="upper right")
    if title:
        figure.suptitle(title)
    return figure


def _draw_floor(ax: Axes, grid: WarehouseGrid, target: tuple[int, int]) -> None:
    """Cell borders, shelves, the start and the target on ``ax``, row 0 at the top."""
    ax.set_xlim(-0.5, grid.cols - 0.5)
    ax.set_ylim(grid.rows - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xticks(range(grid.cols))
    ax.set_yticks(range(grid.rows))
    ax.set_xticks(np.arange(-0.5, grid.cols), minor=True)
    ax.set_yticks(np.arange(-0.5, grid.rows), minor=True)
    ax.grid(which="minor", color="0.8")
    ax.tick_params(which="minor", length=0)
    ax.set_xlabel("column")
    ax.set_ylabel("row")
    for r, c in grid.shelves:
        ax.add_patch(Rectangle((c - 0.5, r - 0.5), 1, 1, color="0.55"))
    ax.add_patch(
        Rectangle((target[1] - 0.4, target[0] - 0.4), 0.8, 0.8, color="#c8965a", alpha=0.6)
    )
    ax.plot(grid.start[1], grid.start[0], "o", color="0.3", markersize=4)


def _histogram_figure(
    values: np.ndarray,
    bins: np.ndarray,
    lines: Sequence[tuple[float, dict[str, str]]],
    *,
    xlabel: str,
    ylabel: str,
    title: str,
) -> tuple[Figure, Axes]:
    """A histogram of ``values`` over ``bins`` with a vertical line at each ``x`` of
    ``lines`` (drawn with its keyword arguments, a ``label`` for the legend), the figure
    of the snap errors and of the fleet's gaps; returns the figure and its axes."""
    figure = new_figure(figsize=(6.5, 3.2))
    ax = figure.subplots()
    ax.hist(values, bins=bins, color="C0")
    for x, style in lines:
        ax.axvline(x, **style)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(title)
    return figure, ax


__all__ = [
    "PLANNER_LABELS",
    "ROLLING_WINDOW",
    "TITLE_SHARE",
    "TITLE_WIDTH",
    "congestion_figure",
    "fleet_delay_figure",
    "fleet_gap_figure",
    "frame_strips_figure",
    "learning_curve_figure",
    "learning_curves_figure",
    "path_figure",
    "planner_scaling_figure",
    "policy_figure",
    "rolling_mean",
    "save_figure",
    "snap_error_figure",
    "speed_profile_figure",
    "sweep_figure",
    "throughput_by_robots_figure",
    "throughput_figure",
]
