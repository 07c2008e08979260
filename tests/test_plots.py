"""Learning-curve pictures: the rolling mean and the figure, drawn without pyplot."""

import numpy as np
import pytest

from warehouse_phys.plots import learning_curve_figure, rolling_mean, save_figure
from warehouse_phys.qlearning import QLearningConfig, TrainingResult


def test_rolling_mean_averages_the_last_window_values():
    values = np.array([4, 2, 6, 8, 0])
    assert rolling_mean(values, 2).tolist() == [4, 3, 4, 7, 4]
    assert rolling_mean(values, 1).tolist() == values.tolist()
    assert rolling_mean(values, 10).tolist() == [4, 3, 4, 5, 4]
    with pytest.raises(ValueError, match="window must be at least 1"):
        rolling_mean(values, 0)


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
        "from tests.test_plots import fake_result\n"
        "from warehouse_phys.plots import learning_curve_figure\n"
        "learning_curve_figure(fake_result())\n"
        "print('matplotlib.pyplot' in sys.modules)\n"
    )
    assert run_python(script).strip() == "False"
