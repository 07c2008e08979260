"""Figures of lifelong fleet runs: throughput over time (:func:`throughput_figure`), where
robots waited (:func:`congestion_figure`), throughput against fleet size
(:func:`throughput_by_robots_figure`), the planners' scaling beside the congestion-free
ceiling (:func:`planner_scaling_figure`) and an evaluation suite's fractions of the best
known solutions (:func:`suite_figure`).
"""

from __future__ import annotations

import json
import os
import textwrap
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from warehouse_phys.viz.figures import free_mask, new_figure, rolling_mean
from warehouse_phys.world.grid import WarehouseGrid

#: Characters a line of a figure's title holds at most before it wraps.
TITLE_WIDTH = 80
#: The share of a figure's width a wrapped title may take: the axes it is centred on sit
#: a little off the figure's centre (the y label is on their left).
TITLE_SHARE = 0.85


def _set_wrapped_title(ax: Axes, title: str) -> None:
    """Set ``ax``'s title wrapped into lines that fit the figure's width (measured with the
    figure's renderer; at spaces, and inside a word only where one line cannot hold it),
    so that no part of it is cut off."""
    figure = ax.get_figure()
    renderer = figure.canvas.get_renderer()
    room = figure.bbox.width * TITLE_SHARE
    for width in range(TITLE_WIDTH, 9, -4):
        ax.set_title(textwrap.fill(title, width))
        if ax.title.get_window_extent(renderer).width <= room:
            return


def throughput_figure(
    deliveries: np.ndarray, title: str = "", window: int = 32, unit: str = "step"
) -> Figure:
    """Deliveries at each step (``unit``: each tick of a run on ticks) of a lifelong run,
    and their rolling mean over ``window`` of them: the throughput over time
    [deliveries/step]. The whole title shows, wrapped to the figure's width, and the
    legend stands under the axes, off the data."""
    deliveries = np.asarray(deliveries, dtype=np.float64)
    figure = new_figure((7, 3.6))
    ax = figure.add_subplot()
    steps = np.arange(1, len(deliveries) + 1)
    ax.plot(steps, deliveries, color="#bbbbbb", linewidth=0.8, label=f"deliveries at the {unit}")
    ax.plot(steps, rolling_mean(deliveries, window), color="#0072B2", linewidth=2,
            label=f"mean of the last {window} {unit}s")  # fmt: skip
    mean = deliveries.mean() if len(deliveries) else 0.0
    digits = 2 if unit == "step" else 3  # a tick delivers a tenth of a step's
    ax.axhline(mean, color="#D55E00", linestyle="--", linewidth=1,
               label=f"throughput {mean:.{digits}f} deliveries/{unit}")  # fmt: skip
    ax.set_xlabel(unit)
    ax.set_ylabel("deliveries")
    # Outside the axes: inside, any corner covers the lines on some floor (a run that
    # delivers nothing draws them along the bottom, a busy one along the top).
    figure.legend(loc="outside lower center", ncols=3, fontsize="small", frameon=False)
    _set_wrapped_title(ax, title or "Throughput over time")
    return figure


def congestion_figure(grid: WarehouseGrid, waits: np.ndarray, title: str = "") -> Figure:
    """Where robots waited: a heatmap of the waits counted on each cell (shelves grey)."""
    waits = np.asarray(waits, dtype=np.float64).reshape(grid.rows, grid.cols)
    shown = np.ma.masked_array(waits, mask=~free_mask(grid))
    aspect = grid.cols / grid.rows
    # The map's own shape, at most 12 inches wide or tall, plus room for the title and
    # the colour bar: a 500 x 140 floor gets a wide, low figure, not blank bands.
    width, height = (12.0, 12.0 / aspect) if aspect >= 1 else (12.0 * aspect, 12.0)
    scale = min(1.0, 8.0 / height) if aspect >= 1 else 8.0 / height
    figure = new_figure((max(4.0, width * scale) + 1.5, max(2.0, height * scale) + 0.8))
    ax = figure.add_subplot()
    ax.set_facecolor("#808080")
    image = ax.imshow(shown, cmap="magma_r", interpolation="nearest")
    figure.colorbar(image, ax=ax, label="waits on the cell", shrink=min(1.0, 0.4 + 0.6 / aspect))
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title or f"Congestion: {int(waits.sum()):,} waits")
    return figure


def throughput_by_robots_figure(
    throughput: Mapping[int, float], published: Mapping[str, float] | None = None, title: str = ""
) -> Figure:
    """Throughput [deliveries/step] against the number of robots, with ``published``
    figures (name to value) drawn as dashed lines for comparison."""
    figure = new_figure((6, 3))
    ax = figure.add_subplot()
    robots = sorted(throughput)
    ax.plot(robots, [throughput[n] for n in robots], "o-", color="#0072B2", label="measured")
    palette = ("#D55E00", "#009E73", "#CC79A7", "#E69F00")
    for i, (name, value) in enumerate((published or {}).items()):
        ax.axhline(value, color=palette[i % len(palette)], linestyle="--", linewidth=1, label=name)
    ax.set_xlabel("robots")
    ax.set_ylabel("deliveries per step")
    ax.set_title(title or "Throughput against fleet size")
    ax.legend(fontsize="small")
    return figure


#: Names the planners go by in figures.
PLANNER_LABELS = {"pibt": "PIBT", "guided": "guided PIBT"}


def planner_scaling_figure(scaling: Mapping[str, object] | str | os.PathLike[str]) -> Figure:
    """Errands a step against robots, each planner's (over the whole run, dotted, and its
    last half) beside the congestion-free ceiling (robots over the mean shortest distance
    between consecutive errands, dashed): ``benchmarks/planners.py --scaling``'s results,
    given as its ``"scaling"`` mapping or as the path of the JSON file it wrote.

    Raises:
        ValueError: if the file holds no scaling runs.
    """
    if not isinstance(scaling, Mapping):
        scaling = json.loads(Path(scaling).read_text(encoding="utf-8")).get("scaling")
        if not scaling:
            raise ValueError("the file holds no scaling runs (benchmarks/planners.py --scaling)")
    rows = list(scaling["rows"])
    robots = sorted({row["robots"] for row in rows})
    ceiling = {row["robots"]: row["ceiling"] for row in rows if row.get("ceiling") is not None}
    figure = new_figure((6.4, 4.2))
    ax = figure.add_subplot()
    ax.plot([n for n in robots if n in ceiling], [ceiling[n] for n in robots if n in ceiling],
            "k--", marker="o", label="congestion-free ceiling")  # fmt: skip
    for name in dict.fromkeys(row["planner"] for row in rows):
        mine = sorted((row for row in rows if row["planner"] == name), key=lambda r: r["robots"])
        label = PLANNER_LABELS.get(name, name)
        sizes = [row["robots"] for row in mine]
        (line,) = ax.plot(sizes, [row["errands_per_step_last_half"] for row in mine],
                          marker="o", label=f"{label} (last half)")  # fmt: skip
        ax.plot(sizes, [row["errands_per_step"] for row in mine], marker=".", linestyle=":",
                color=line.get_color(), label=f"{label} (whole run)")  # fmt: skip
    ax.set_xlabel("robots")
    ax.set_ylabel("errands a step")
    ax.set_title(f"{scaling['layout']}, lifelong, {scaling['steps']} steps, seed 0")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return figure


def suite_figure(rows: list[Mapping[str, object]], title: str = "") -> Figure:
    """An evaluation suite's results (``python -m warehouse_phys.evaluate``'s rows): for
    each instance, a bar per planner, the mean over its seeds of the fraction of the best
    known solution, with the 0.9 mark, each bar's figure written on it (where the
    instance has no best known, no bar: its throughput a step, written at the foot)."""
    instances = list(dict.fromkeys(str(row["instance"]) for row in rows))
    planners = list(dict.fromkeys(str(row["planner"]) for row in rows))
    figure = new_figure((max(5.0, 1.1 * len(instances) * max(1, len(planners)) + 2), 3.8))
    ax = figure.add_subplot()
    width = 0.8 / max(1, len(planners))
    for k, planner in enumerate(planners):
        for i, instance in enumerate(instances):
            mine = [r for r in rows if r["instance"] == instance and r["planner"] == planner]
            if not mine:
                continue
            fractions = [r["fraction_of_best"] for r in mine]
            known = all(f is not None for f in fractions)
            value = float(np.mean(fractions if known else [r["per_step"] for r in mine]))
            bar = ax.bar(i + (k - (len(planners) - 1) / 2) * width, value if known else 0.0,
                         width, color=f"C{k}", label=planner if i == 0 else None)  # fmt: skip
            text = f"{value:.2f}" if known else f"{value:.1f}/step"
            ax.bar_label(bar, [text], fontsize=7, rotation=90, padding=2)
    ax.axhline(0.9, color="#D55E00", linestyle="--", linewidth=1, label="0.9 of best known")
    ax.set_xticks(range(len(instances)), instances, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("fraction of the best known")
    ax.set_ylim(0, 1.35)
    ax.legend(fontsize="small", ncols=3, loc="upper left")
    _set_wrapped_title(ax, title or "Evaluation suite")
    return figure
