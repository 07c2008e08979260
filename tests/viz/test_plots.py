"""Pictures: learning curves, frames, paths, speeds, snap errors and policies, without pyplot."""

import numpy as np
import pytest

from warehouse_phys import SNAP_ERROR_BOUND, Action, WarehouseGrid
from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.rl.fleet_learning import FleetEvaluation
from warehouse_phys.rl.qlearning import QLearningConfig, TrainingResult, new_q_table
from warehouse_phys.viz.figures import rolling_mean, save_figure
from warehouse_phys.viz.plots import (
    fleet_delay_figure,
    fleet_gap_figure,
    frame_strips_figure,
    learning_curve_figure,
    learning_curves_figure,
    path_figure,
    policy_figure,
    snap_error_figure,
    speed_profile_figure,
)


def fake_result(episodes=250):
    rng = np.random.default_rng(0)
    steps = np.maximum(1, (60 * np.exp(-np.arange(episodes) / 50)).astype(int))
    reached = rng.random(episodes) < 0.9
    return TrainingResult(
        q=np.zeros((2, 2, 2, 2, 4)),
        config=QLearningConfig(episodes=episodes),
        steps=steps,
        returns=reached.astype(float),
        reached_target=reached,
        truncated=~reached,
        epsilon=np.linspace(1, 0, episodes),
    )


def test_learning_curve_shows_rolling_steps_and_success(tmp_path, run_python):
    result = fake_result()
    figure = learning_curve_figure(result, title="a run")
    steps_axes, success_axes = figure.axes
    rolling = steps_axes.get_lines()[1].get_ydata()
    assert np.allclose(rolling, rolling_mean(result.steps, 100))
    assert success_axes.get_lines()[0].get_ydata() == pytest.approx(
        rolling_mean(result.reached_target, 100)
    )
    assert figure.get_suptitle() == "a run"
    path = save_figure(figure, tmp_path / "curve.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["curve.png"]


def test_plots_never_load_pyplot(run_python):
    script = (
        "import sys\n"
        "from tests.viz.test_plots import fake_result\n"
        "from tests.viz.test_plots import every_figure\n"
        "every_figure()\n"
        "print('matplotlib.pyplot' in sys.modules)\n"
    )
    assert run_python(script).strip() == "False"


def every_figure():
    """One of each figure, from made-up data."""
    grid = WarehouseGrid.from_layout(["S..", ".#.", "..P"])
    q = new_q_table(3, 3)
    q[0, 0, 2, 2, Action.RIGHT] = 0.5
    frame = np.zeros((40, 50, 3), np.uint8)
    return [
        learning_curve_figure(fake_result()),
        learning_curves_figure({"a": fake_result(), "b": fake_result()}),
        frame_strips_figure({"row": [frame, frame]}),
        path_figure(grid, np.array([[0, 0], [0, 1]]), (2, 2), np.array([[0, 0.5], [0, 1]])),
        speed_profile_figure(np.array([0.1, 0.2]), np.array([1.0, 0.0]), PhysicsConfig()),
        snap_error_figure(np.array([0.001, 0.002]), SNAP_ERROR_BOUND),
        policy_figure(q, grid, (2, 2)),
    ]


def test_learning_curves_side_by_side_share_their_axes():
    a, b = fake_result(), fake_result(120)
    figure = learning_curves_figure({"grid twin": a, "physics": b}, title="both")
    top_left, top_right, bottom_left, bottom_right = figure.axes
    assert [top_left.get_title(), top_right.get_title()] == ["grid twin", "physics"]
    assert np.allclose(top_right.get_lines()[1].get_ydata(), rolling_mean(b.steps, 100))
    assert top_left.get_shared_y_axes().joined(top_left, top_right)
    assert bottom_left.get_shared_x_axes().joined(bottom_left, bottom_right)
    assert figure.get_suptitle() == "both"
    with pytest.raises(ValueError, match="results is empty"):
        learning_curves_figure({})


def test_frame_strips_show_each_frame_with_its_caption():
    frames = [np.full((40, 50, 3), i, np.uint8) for i in range(3)]
    figure = frame_strips_figure(
        {"top": frames, "bottom": frames[:2]}, captions={"top": ["a", "b", "c"]}
    )
    images = [ax.get_images()[0].get_array() for ax in figure.axes if ax.get_images()]
    assert len(images) == 5
    assert [int(image[0, 0, 0]) for image in images] == [0, 1, 2, 0, 1]
    assert [ax.get_title() for ax in figure.axes[:3]] == ["a", "b", "c"]
    assert {text.get_text() for ax in figure.axes for text in ax.texts} == {"top", "bottom"}
    with pytest.raises(ValueError, match="every strip needs at least one frame"):
        frame_strips_figure({"empty": []})


def test_path_figure_draws_cells_and_the_body_path_in_grid_coordinates():
    grid = WarehouseGrid.from_layout(["S..", ".#.", "..P"])
    cells = np.array([[0, 0], [0, 1], [0, 2]])
    path = np.array([[0, 0.4], [0, 1.0], [0.01, 1.6], [0, 2]])
    figure = path_figure(grid, cells, (2, 2), path, title="t")
    (ax,) = figure.axes
    cell_line, body_line = (line for line in ax.get_lines() if len(line.get_xdata()) > 1)
    assert cell_line.get_xdata().tolist() == [0, 1, 2]  # x is the column
    assert body_line.get_ydata().tolist() == path[:, 0].tolist()  # y is the row
    assert ax.get_ylim() == (2.5, -0.5)  # row 0 at the top
    # The shelf and the target are drawn as patches on their cells.
    corners = sorted(patch.get_xy() for patch in ax.patches)
    assert corners == [(0.5, 0.5), (1.6, 1.6)]


def test_speed_profile_figure_marks_the_limit_and_the_settle_phase():
    config = PhysicsConfig()
    times, speeds = np.array([0.1, 0.2]), np.array([6.0, 1.0])
    (ax,) = speed_profile_figure(times, speeds, config).axes
    limit, curve = ax.get_lines()
    assert limit.get_ydata()[0] == config.max_speed
    assert curve.get_ydata().tolist() == [6.0, 1.0]
    (settle,) = ax.patches  # a rectangle over the settle phase
    assert settle.get_x() == pytest.approx(config.move_duration - config.settle_time)
    assert settle.get_x() + settle.get_width() == pytest.approx(config.move_duration)


def test_snap_error_histogram_counts_every_move_against_the_bound():
    errors = np.array([0.001, 0.001, 0.004, 0.0045])
    (ax,) = snap_error_figure(errors, 0.02).axes
    assert sum(patch.get_height() for patch in ax.patches) == 4
    bound, largest = ax.get_lines()
    assert bound.get_xdata()[0] == 0.02
    assert largest.get_xdata()[0] == 0.0045
    assert ax.get_title() == "4 moves"
    with pytest.raises(ValueError, match="no snap errors"):
        snap_error_figure(np.array([]), 0.02)


def test_policy_figure_draws_one_arrow_per_trained_cell_and_every_value():
    grid = WarehouseGrid.from_layout(["S..", ".#.", "..P"])
    q = new_q_table(3, 3)
    q[0, 0, 2, 2, Action.RIGHT] = 0.5
    q[1, 2, 2, 2, Action.DOWN] = 1.0
    policy_ax, value_ax, _colorbar = policy_figure(q, grid, (2, 2)).axes
    (quiver,) = policy_ax.collections
    directions = sorted(map(tuple, np.column_stack([quiver.U, quiver.V]).tolist()))
    assert directions == [(0.0, 1.0), (1.0, 0.0)]  # DOWN (row + 1) and RIGHT
    texts = sorted(text.get_text() for text in value_ax.texts)
    # Seven floor cells show a value; the shelf none; the target says what it is.
    assert texts == ["0.00"] * 5 + ["0.50", "1.00", "target"]


def test_figures_save_as_png(tmp_path):
    for i, figure in enumerate(every_figure()):
        assert save_figure(figure, tmp_path / f"{i}.png").read_bytes()[:4] == b"\x89PNG"


def test_fleet_gap_histogram_marks_touching_and_the_corner_follow():
    gaps = np.array([0.107, 0.4, 0.4, 1.0, np.inf])  # inf: a robot alone, nothing to measure
    figure = fleet_gap_figure(gaps, PhysicsConfig())
    (ax,) = figure.axes
    assert sum(patch.get_height() for patch in ax.patches) == 4
    lines = [line.get_xdata()[0] for line in ax.lines]
    assert lines[0] == 0.0
    assert lines[1] == pytest.approx(np.sqrt(0.5) - 0.6)
    assert lines[2] == pytest.approx(0.107)
    with pytest.raises(ValueError, match="no gaps"):
        fleet_gap_figure(np.array([np.inf]), PhysicsConfig())


def test_fleet_delay_figure_shows_steps_against_shortest_paths_and_misses():
    learned = FleetEvaluation(20, 3, 50, 180, 170, 40, 5)
    baseline = FleetEvaluation(20, 3, 55, 210, 190, 2, 3)
    figure = fleet_delay_figure({"learned": learned, "shortest paths": baseline})
    steps_ax, missed_ax = figure.axes
    assert [p.get_height() for p in steps_ax.patches] == [170, 190, 180, 210]
    assert [p.get_height() for p in missed_ax.patches] == [10, 5]
    with pytest.raises(ValueError, match="nothing to plot"):
        fleet_delay_figure({})


def test_a_sweep_whose_trials_all_failed_draws_without_a_warning():
    """Configurations with no finished seed draw no curve: no legend, and no matplotlib
    warning (which the suite turns into an error) about a legend without artists."""
    from warehouse_phys.viz.plots import sweep_figure

    figure = sweep_figure({"grid, default": [], "phys, default": []}, title="all failed")
    (optimal_axes, curve_axes) = figure.axes
    assert curve_axes.get_legend() is None
    assert [tick.get_text() for tick in optimal_axes.get_yticklabels()] == [
        "grid, default",
        "phys, default",
    ]
