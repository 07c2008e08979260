"""Figures of lifelong fleet runs: throughput over time, congestion, throughput against
fleet size and the planners' scaling."""

import json

import numpy as np
import pytest

from warehouse_phys import WarehouseGrid
from warehouse_phys.viz.throughput_figures import (
    congestion_figure,
    planner_scaling_figure,
    throughput_by_robots_figure,
    throughput_figure,
)


def test_throughput_figure_shows_each_step_its_rolling_mean_and_the_throughput():
    deliveries = np.array([0, 2, 4, 2] * 10)
    title = "pibt, 192 robots on kiva-33-46, 40 steps (new_package): " + "measures " * 10
    figure = throughput_figure(deliveries, title, window=4)
    (ax,) = figure.axes
    raw, mean, level = ax.lines
    assert list(raw.get_ydata()) == deliveries.tolist()
    assert mean.get_ydata()[-1] == 2.0
    assert level.get_ydata()[0] == 2.0
    (legend,) = figure.legends
    assert "throughput 2.00 deliveries/step" in [t.get_text() for t in legend.texts]
    assert "\n" in ax.get_title()  # a long title wraps rather than being cut off


def within(inner, outer):
    """Whether the box ``inner`` lies inside ``outer`` (display coordinates)."""
    return bool((outer.min <= inner.min).all() and (inner.max <= outer.max).all())


LONG_SUMMARY = (
    "pibt, 1,000 robots on warehouse-large-140-500, 256 steps (new_package): throughput "
    "1.39 deliveries/step, 89 deliveries, 507 waits, 0 refused moves; 990/1,000 delivered "
    "(3 walled off), makespan 256, sum of costs 12,345 against 10,000 on shortest paths"
)


@pytest.mark.parametrize(
    "deliveries",
    [np.zeros(256), np.full(256, 9.0), np.r_[np.zeros(100), np.full(156, 5.0)],
     np.random.default_rng(0).poisson(4, 256).astype(float)],
    ids=["nothing delivered", "steady", "late start", "busy"],
)  # fmt: skip
@pytest.mark.parametrize(
    "title",
    [LONG_SUMMARY, "qtable.npz, 4 robots on /a/long/path/with_no_spaces/" + "x" * 90 + ".txt",
     ""],
    ids=["summary", "unbroken path", "no title"],
)  # fmt: skip
def test_the_throughput_title_shows_whole_and_the_legend_stays_off_the_data(deliveries, title):
    figure = throughput_figure(deliveries, title)
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    (ax,) = figure.axes
    shown = ax.title.get_window_extent(renderer)
    page = figure.bbox
    assert within(shown, page)
    assert ax.get_title().replace("\n", "").replace(" ", "") == (
        title or "Throughput over time"
    ).replace(" ", "")  # wrapped, nothing dropped
    (legend,) = figure.legends
    box = legend.get_window_extent(renderer)
    assert not box.overlaps(ax.get_window_extent(renderer))  # outside the axes
    assert within(box, page)


def test_congestion_figure_fits_the_floors_shape_and_greys_the_shelves():
    grid = WarehouseGrid.from_layout(["." * 40, "." + "#" * 38 + ".", *["." * 40] * 8])
    waits = np.zeros((10, 40))
    waits[0, 3] = 7
    figure = congestion_figure(grid, waits)
    width, height = figure.get_size_inches()
    assert width / height > 2.5  # a wide floor, a wide figure
    image = figure.axes[0].images[0]
    assert image.get_array().mask[1, 5]  # a shelf: masked, drawn grey
    assert image.get_array().max() == 7
    assert figure.axes[0].get_title() == "Congestion: 7 waits"


def test_throughput_by_robots_draws_the_measures_and_published_lines():
    figure = throughput_by_robots_figure({128: 3.4, 64: 2.0}, {"paper": 3.0})
    (ax,) = figure.axes
    assert list(ax.lines[0].get_xdata()) == [64, 128]
    assert ax.lines[1].get_ydata()[0] == 3.0


SCALING = {
    "layout": "warehouse-large-140-500.map",
    "steps": 500,
    "rows": [
        {"planner": name, "robots": n, "errands_per_step": run, "errands_per_step_last_half": last,
         "ceiling": ceiling}
        for name, n, run, last, ceiling in [
            ("pibt", 2000, 6.7, 8.0, 9.35), ("guided", 2000, 7.7, 9.2, 9.35),
            ("pibt", 1000, 3.6, 4.4, 4.65), ("guided", 1000, 3.8, 4.5, 4.65),
        ]
    ],
}  # fmt: skip


def test_the_planner_scaling_figure_draws_the_ceiling_and_each_planners_two_rates(tmp_path):
    figure = planner_scaling_figure(SCALING)
    (ax,) = figure.axes
    ceiling, pibt_last, pibt_run, guided_last, guided_run = ax.lines
    assert list(ceiling.get_xdata()) == [1000, 2000]
    assert list(ceiling.get_ydata()) == [4.65, 9.35]
    assert list(pibt_last.get_ydata()) == [4.4, 8.0]  # sorted by robots
    assert list(pibt_run.get_ydata()) == [3.6, 6.7]
    assert list(guided_last.get_ydata()) == [4.5, 9.2]
    assert list(guided_run.get_ydata()) == [3.8, 7.7]
    assert [text.get_text() for text in ax.get_legend().get_texts()][1:] == [
        "PIBT (last half)", "PIBT (whole run)", "guided PIBT (last half)",
        "guided PIBT (whole run)"]  # fmt: skip
    # The benchmark's JSON file gives the same figure; one without scaling runs is refused.
    path = tmp_path / "planners.json"
    path.write_text(json.dumps({"scaling": SCALING}))
    assert list(planner_scaling_figure(path).axes[0].lines[2].get_ydata()) == [3.6, 6.7]
    path.write_text(json.dumps({"scaling": None}))
    with pytest.raises(ValueError, match="no scaling runs"):
        planner_scaling_figure(path)
