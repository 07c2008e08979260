"""The batched world's floors: far enough apart that no robot reaches another, numbered
and started on free cells, and every pair of robots within reach on one floor compared."""

import numpy as np
import pytest

from warehouse_phys.physics import PhysicsConfig, penetration
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.floor_lattice import GAP_REACH
from warehouse_phys.physics.lockstep import ACTION_DELTA_ARRAY
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import resolve_layout

CONFIG = PhysicsConfig()
FLOORS = {"default": WarehouseGrid(4, 5)}


def starts_for(grid, n):
    return np.tile(np.array(grid.start, dtype=np.int64), (n, 1))


def test_floors_are_far_enough_apart_that_no_robot_reaches_another_floor():
    grid = resolve_layout("maze")
    world = BatchedPhysicsWorld(grid, CONFIG, starts_for(grid, 30), record_path=True)
    rng = np.random.default_rng(3)
    radius = CONFIG.robot_radius / CONFIG.cell_size
    for _ in range(100):
        world.move_by(rng.integers(4, size=30))
        for path in world.last_paths:  # on its own floor's cells, never deep in a wall
            assert penetration(grid, radius, path).max() < 0.1


@pytest.mark.parametrize(
    ("starts", "floor_of", "message"),
    [
        ([(0, 5)], None, r"robot 0's start \(0, 5\) is off the 4x5 floor"),
        ([(0, 0), (0, 0)], [0, 0], r"robots \[0, 1\] start on the same cell"),
        ([(0, 0), (1, 1)], [0, 2], "floors must be numbered 0, 1, ..."),
        ([(0, 0), (1, 1)], [0], "floor_of must have one floor per robot"),
        (np.zeros((0, 2), dtype=int), None, "at least one robot"),
    ],
)
def test_bad_starts_and_floors_are_refused(starts, floor_of, message):
    with pytest.raises(ValueError, match=message):
        BatchedPhysicsWorld(FLOORS["default"], CONFIG, starts, floor_of)


@pytest.mark.parametrize("n_floors", [1, 3])
def test_the_closest_approach_is_every_pair_within_reach_compared(n_floors):
    grid = WarehouseGrid(12, 12)
    rng = np.random.default_rng(5)
    n = 60
    floor_of = np.arange(n) % n_floors
    cells = np.stack(np.divmod(rng.choice(144, n, replace=False), 12), axis=1)
    world = BatchedPhysicsWorld(grid, PhysicsConfig(), cells, floor_of, record_path=True)
    assert np.isinf(world.closest_approach()).all()  # no move yet
    for _ in range(3):
        starts = world.cells.copy()
        aims = starts + ACTION_DELTA_ARRAY[rng.integers(4, size=n)]
        world.move(np.where(rng.random((n, 1)) < 0.7, aims, starts))  # robots may overlap
        paths = world.last_paths  # (N, steps, 2)
        every_pair = np.linalg.norm(paths[:, None] - paths[None, :], axis=-1).min(axis=-1)
        start_apart = np.abs(starts[:, None] - starts[None, :]).sum(axis=-1)
        others = (floor_of[:, None] == floor_of[None, :]) & ~np.eye(n, dtype=bool)
        compared = others & (start_apart <= GAP_REACH)
        expected = np.where(compared, every_pair, np.inf).min(axis=1)
        assert np.array_equal(world.closest_approach(), expected)
        assert np.isfinite(expected).any()
        assert (every_pair[others & ~compared] > 0.99).all()  # never near the others
