"""python -m warehouse_phys.simulate: the measures, the run folder and clear errors."""

import json

import numpy as np
import pytest

from warehouse_phys import fleet
from warehouse_phys.fleet_evaluation import shortest_path_policy
from warehouse_phys.render import MAP_PACKAGE, MAP_ROBOT_COLOURS, fleet_map_frame
from warehouse_phys.simulate import main, simulate


def test_the_simulation_counts_deliveries_waits_and_frames():
    env = fleet.parallel_env(num_robots=5, layout="aisles", lifelong=True, max_cycles=40)
    result, frames = simulate(env, shortest_path_policy, steps=40, seed=1, frames=8)
    assert result.steps == 40
    assert result.throughput == result.deliveries.sum() / 40
    assert result.deliveries.sum() == env.deliveries.sum()
    assert result.waits.shape == (7, 9)
    assert (
        result.waits[[r for r, _ in env.grid.shelves], [c for _, c in env.grid.shelves]].sum() == 0
    )
    assert len(frames) == 8  # the first, then evenly spread
    assert frames[0].shape == (7 * 24, 9 * 24, 3)


def test_the_command_writes_its_run_folder(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["--layout", "aisles", "--robots", "4", "--steps", "30", "--policy",
                 "shortest", "--frames", "4", "--out", str(out), "--quiet"]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "throughput" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 30
    assert summary["policy"] == "shortest"
    assert len(summary["deliveries_per_step"]) == 30
    assert sorted(p.name for p in out.iterdir()) == [
        "congestion.png", "fleet.gif", "summary.json", "throughput.png"
    ]  # fmt: skip
    assert main(["--robots", "2", "--steps", "3", "--out", str(out), "--quiet",
                 "--policy", "random"]) == 2  # fmt: skip
    assert "--out" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--policy", "magic"], "unknown policy 'magic'"),
        (["--robots", "300"], "300 robots need"),
        (["--layout", "nowhere"], "unknown layout"),
        (["--on-delivery", "vanish"], "invalid choice: 'vanish'"),
        (["--layout", "aisles", "--rows", "5"], "not both"),
        (["--policy", "missing.npz"], "missing.npz"),
    ],
)
def test_bad_arguments_end_in_one_line(argv, message, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path / "x"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_map_frames_show_robots_packages_and_shelves_in_array_colours():
    env = fleet.parallel_env(num_robots=3, layout="aisles")
    env.reset(seed=0)
    frame = fleet_map_frame(env.grid, env.robot_cells, env.package_cells, cell_px=6)
    assert frame.shape == (7 * 6, 9 * 6, 3)
    for i, (row, col) in enumerate(env.robot_cells.tolist()):
        assert (frame[row * 6, col * 6] == MAP_ROBOT_COLOURS[i]).all()
    for row, col in env.package_cells.tolist():
        assert (frame[row * 6 + 3, col * 6 + 3] == MAP_PACKAGE).all()
    # A package under a robot stays visible in the robot's middle.
    cells = np.array([[0, 0]])
    frame = fleet_map_frame(env.grid, cells, cells, cell_px=6)
    assert (frame[0, 0] == MAP_ROBOT_COLOURS[0]).all()
    assert (frame[3, 3] == MAP_PACKAGE).all()
    assert len({tuple(c) for c in MAP_ROBOT_COLOURS.tolist()}) == 8
