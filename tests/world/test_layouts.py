"""The warehouse layout presets and their registered environments."""

import ast
from pathlib import Path

import gymnasium as gym
import pytest

import warehouse_phys
from warehouse_phys import layouts as layouts_module
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import (
    PRESETS,
    preset_ids,
    preset_name,
    resolve_layout,
    suggested_time_limit,
)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_are_valid_warehouses_with_detours(name):
    preset = PRESETS[name]
    grid = resolve_layout(name)
    assert grid.layout == preset.rows
    assert len(grid.shelves) >= 6  # shelves, not an empty floor
    assert grid.target_cells
    # Somewhere the shelves make the shortest path longer than the Manhattan distance.
    assert any(
        grid.optimal_steps(cell, t) > abs(t[0] - cell[0]) + abs(t[1] - cell[1])
        for cell in grid.reachable
        for t in grid.target_cells
    )
    assert preset.description


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_time_limits_let_random_walks_finish(name):
    grid = resolve_layout(name)
    limit = PRESETS[name].max_episode_steps
    assert limit == suggested_time_limit(grid)
    assert grid.random_walk_finish_rate(limit) >= 0.98
    assert grid.random_walk_finish_rate(limit - 100) < 0.98


def test_suggested_time_limit_of_the_default_floor_is_its_registered_limit():
    assert suggested_time_limit(WarehouseGrid(4, 5)) == warehouse_phys.DEFAULT_MAX_EPISODE_STEPS


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_each_preset_is_registered_in_both_worlds(name):
    grid_id, physics_id = preset_ids(name)
    assert (grid_id, physics_id) == (
        f"warehouse-robot-{name}-v0",
        f"warehouse-robot-phys-{name}-v0",
    )
    for env_id, cls in (
        (grid_id, warehouse_phys.WarehouseGridEnv),
        (physics_id, warehouse_phys.WarehousePhysicsEnv),
    ):
        env = gym.make(env_id)
        assert type(env.unwrapped) is cls
        assert env.spec.max_episode_steps == PRESETS[name].max_episode_steps
        assert env.unwrapped.grid.layout == PRESETS[name].rows
        rows, cols = len(PRESETS[name].rows), len(PRESETS[name].rows[0])
        assert env.observation_space == gym.spaces.MultiDiscrete([rows, cols, rows, cols])


def test_preset_name_recognises_only_the_presets_rows():
    assert preset_name(PRESETS["depot"].rows) == "depot"
    assert preset_name(list(PRESETS["maze"].rows)) == "maze"
    assert preset_name(["S.", ".P"]) is None


def test_unknown_preset_names_the_known_ones():
    with pytest.raises(ValueError, match="unknown layout preset 'office'; presets: aisles, depot"):
        resolve_layout("office")


@pytest.mark.parametrize("module", ["layouts", "maps", "movingai"])
def test_layouts_module_imports_no_simulation_or_gui_library(module):
    path = Path(layouts_module.__file__).with_name(f"{module}.py")
    tree = ast.parse(path.read_text())
    imported = {
        (node.module or "").split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
    } | {
        alias.name.split(".")[0]
        for node in ast.walk(tree)
        if isinstance(node, ast.Import)
        for alias in node.names
    }
    assert not imported & {"gymnasium", "gym", "pymunk", "pygame"}


# 10 x 10, the largest and dearest, is checked by the next test, which computes its limit anyway.
@pytest.mark.parametrize("size", [(6, 6), (8, 8)])
def test_small_floors_get_the_exact_random_walk_limit(size):
    grid = WarehouseGrid(*size)
    limit = suggested_time_limit(grid)
    assert grid.random_walk_finish_rate(limit) >= 0.98
    assert grid.random_walk_finish_rate(limit - 100) < 0.98


@pytest.mark.parametrize(
    ("grid", "limit"),
    [
        (WarehouseGrid(10, 11), 1400),  # 110 cells: 12 each, rounded up to 100
        (WarehouseGrid(100, 100), 120_000),
        (WarehouseGrid(512, 512), 3_145_800),
        (WarehouseGrid.from_layout(["S" + "." * 119, "#" * 119 + "."]), 1500),  # 121 reachable
    ],
)
def test_larger_floors_get_twelve_steps_per_reachable_cell(grid, limit):
    assert len(grid.reachable) > 100
    assert suggested_time_limit(grid) == limit


def test_the_exact_limit_does_not_rerun_the_walk_for_every_candidate_and_is_exact():
    """The 14 x 14 floor took 93 s when each candidate limit restarted the walk. On the
    10 x 10 floor the limit is also the exact one, as on the smaller floors above."""
    grid = WarehouseGrid(10, 10)
    calls = []
    real = WarehouseGrid._finish_rates

    def counted(self):
        calls.append(1)
        return real(self)

    WarehouseGrid._finish_rates = counted
    try:
        assert suggested_time_limit(grid) == 1200
    finally:
        WarehouseGrid._finish_rates = real
    assert len(calls) == 1
    assert grid.random_walk_finish_rate(1200) >= 0.98
    assert grid.random_walk_finish_rate(1200 - 100) < 0.98


@pytest.mark.parametrize("granularity", [0, -5, 2.5, True])
def test_a_granularity_that_is_not_a_positive_integer_is_refused(granularity):
    with pytest.raises(ValueError, match="granularity must be a positive integer"):
        suggested_time_limit(WarehouseGrid(4, 5), granularity)
