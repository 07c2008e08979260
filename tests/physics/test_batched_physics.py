"""The batched physics world, proven against the single world it generalises."""

import copy
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.physics import SNAP_ERROR_BOUND, PhysicsConfig, PhysicsWorld
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import PRESETS, resolve_layout

CONFIG = PhysicsConfig()
FLOORS = {
    "default": WarehouseGrid(4, 5),
    "2x3": WarehouseGrid(2, 3),
    **{name: resolve_layout(name) for name in PRESETS},
}
#: Body positions may differ from the single world's by no more than this [cells].
TOLERANCE = 1e-9


def starts_for(grid, n):
    return np.tile(np.array(grid.start, dtype=np.int64), (n, 1))


@pytest.mark.parametrize("name", list(FLOORS))
def test_every_robot_moves_as_in_a_single_world_at_every_physics_step(name):
    grid = FLOORS[name]
    n = 9
    batched = BatchedPhysicsWorld(grid, CONFIG, starts_for(grid, n), record_path=True)
    singles = [PhysicsWorld(grid, CONFIG, grid.start, record_path=True) for _ in range(n)]
    rng = np.random.default_rng(7)
    exact = np.ones(n, dtype=bool)
    for move in range(150):
        actions = rng.integers(4, size=n)
        cells, snap_errors = batched.move_by(actions)
        paths = batched.last_paths
        assert paths.shape == (n, CONFIG.steps_per_move, 2)
        for i, world in enumerate(singles):
            result = world.move(int(actions[i]))
            assert tuple(cells[i]) == tuple(result.cell)
            assert abs(snap_errors[i] - result.snap_error) < TOLERANCE
            difference = np.abs(paths[i] - world.last_path).max()
            assert difference < TOLERANCE
            exact[i] &= difference == 0
        assert (snap_errors < SNAP_ERROR_BOUND).all()
        assert np.array_equal(batched.positions(), cells.astype(float))
        if move % 25 == 10:  # restarts reorder the space's bodies: the reads must follow
            chosen = rng.choice(n, size=3, replace=False)
            batched.restart(chosen, starts_for(grid, 3))
            for i in chosen:
                singles[i].restart(grid.start)
    # Floor 0 lies where the single world's floor does: bit for bit (see the module doc).
    assert exact[0]


@settings(max_examples=20)
@given(
    history=st.lists(st.integers(0, 3), max_size=60),
    others=st.lists(st.integers(0, 3), min_size=40, max_size=40),
    robot=st.integers(0, 3),
)
def test_a_restarted_robot_replays_bit_for_bit_whatever_came_before(history, others, robot):
    grid = FLOORS["default"]
    n = 4
    used = BatchedPhysicsWorld(grid, CONFIG, starts_for(grid, n), record_path=True)
    rng = np.random.default_rng(len(history))
    for action in history:
        actions = rng.integers(4, size=n)
        actions[robot] = action
        used.move_by(actions)
    used.restart([robot], starts_for(grid, 1))
    fresh = BatchedPhysicsWorld(grid, CONFIG, starts_for(grid, n), record_path=True)
    for step, action in enumerate(others):
        # The other robots do different things in the two worlds: no influence either.
        a, b = rng.integers(4, size=n), rng.integers(4, size=n)
        a[robot] = b[robot] = action
        used.move_by(a)
        fresh.move_by(b)
        assert np.array_equal(used.last_paths[robot], fresh.last_paths[robot]), step


def test_robots_on_one_floor_are_bodies_that_push_each_other():
    grid = WarehouseGrid(2, 4)
    world = BatchedPhysicsWorld(grid, CONFIG, [(0, 0), (0, 2)], [0, 0], record_path=True)
    world.move(np.array([[0, 1], [0, 1]]))  # both aim at the same cell
    paths = world.last_paths
    gap = np.linalg.norm(paths[0] - paths[1], axis=1).min()
    diameter = 2 * CONFIG.robot_radius / CONFIG.cell_size
    assert gap < diameter + 0.05  # they met...
    assert gap > diameter - 0.05  # ...and neither went through the other
    # A robot on a floor of its own passes through the same cells untouched.
    apart = BatchedPhysicsWorld(grid, CONFIG, [(0, 0), (0, 2)], [0, 1], record_path=True)
    cells, _ = apart.move(np.array([[0, 1], [0, 1]]))
    assert cells.tolist() == [[0, 1], [0, 1]]


def test_copies_and_pickles_continue_bit_for_bit():
    grid = FLOORS["default"]
    world = BatchedPhysicsWorld(grid, CONFIG, starts_for(grid, 6), record_path=True)
    rng = np.random.default_rng(1)
    for move in range(40):
        world.move_by(rng.integers(4, size=6))
        if move == 20:
            world.restart([1, 4], starts_for(grid, 2))
    for duplicate in (copy.deepcopy(world), pickle.loads(pickle.dumps(world))):
        original = copy.deepcopy(world)
        check = np.random.default_rng(2)
        for _ in range(40):
            actions = check.integers(4, size=6)
            assert np.array_equal(original.move_by(actions)[0], duplicate.move_by(actions)[0])
            assert np.array_equal(original.last_paths, duplicate.last_paths)


def test_a_restart_onto_a_taken_cell_is_refused_and_changes_nothing():
    world = BatchedPhysicsWorld(FLOORS["default"], CONFIG, [(0, 0), (1, 1)], [0, 0])
    with pytest.raises(ValueError, match="on the same cell"):
        world.restart([0], [(1, 1)])
    with pytest.raises(ValueError, match="off the 4x5 floor"):
        world.restart([0], [(9, 9)])
    assert world.cells.tolist() == [[0, 0], [1, 1]]
    assert world.move(np.array([[0, 1], [1, 2]]))[0].tolist() == [[0, 1], [1, 2]]


def test_paths_need_recording():
    world = BatchedPhysicsWorld(FLOORS["default"], CONFIG, [(0, 0)])
    with pytest.raises(RuntimeError, match="record_path=True"):
        world.last_paths  # noqa: B018 - the property raises
