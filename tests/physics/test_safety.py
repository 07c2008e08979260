"""The safety measures: the closest approach of two bodies and the contacts deeper than
the collision slop, against brute force over the recorded paths, and counted where bodies
do meet each other or a wall."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.physics import COLLISION_SLOP, PhysicsConfig
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.safety import MEASURED_WITHIN, SafetyRecord
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import resolve_layout

CONFIG = PhysicsConfig()
DELTAS = np.array([(0, -1), (1, 0), (0, 1), (-1, 0), (0, 0)])


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 100_000), n=st.integers(2, 30), threads=st.sampled_from([1, 2]))
def test_the_closest_approach_is_brute_forces_wherever_it_is_below_a_cell(seed, n, threads):
    rng = np.random.default_rng(seed)
    grid = WarehouseGrid(7, 9)
    free = np.argwhere(grid.reachable_mask)
    cells = free[rng.choice(len(free), n, replace=False)]
    world = BatchedPhysicsWorld(grid, CONFIG, cells, np.zeros(n, dtype=np.int64), safety=True,
                                threads=threads)  # fmt: skip
    closest = np.full(n, np.inf)
    for _ in range(6):  # random aims: bodies push, bump and pass
        world.move(np.clip(world.cells + DELTAS[rng.integers(5, size=n)], 0, [6, 8]))
        paths = world.last_paths  # (N, steps, 2) cells
        apart = np.sqrt(((paths[:, None] - paths[None]) ** 2).sum(axis=3)).min(axis=2)
        np.fill_diagonal(apart, np.inf)
        closest = np.minimum(closest, apart.min(axis=1))
    expected = np.where(closest < MEASURED_WITHIN, closest, np.inf)
    assert np.allclose(world.safety.robot_closest, expected, rtol=0, atol=1e-12)
    assert world.safety.steps == 6 * CONFIG.steps_per_move
    deeper = closest < world.safety.bound
    assert (world.safety.robot_body_contacts > 0).tolist() == deeper.tolist()


def test_bodies_driven_into_each_other_count_as_contacts_deeper_than_the_slop():
    world = BatchedPhysicsWorld(WarehouseGrid(2, 3), CONFIG, [(0, 0), (0, 2)], [0, 0],
                                safety=True)  # fmt: skip
    world.move(np.array([(0, 1), (0, 1)]))  # both at the middle cell: they collide
    record = world.safety
    assert record.body_contacts == 1  # one pair, once this move
    assert record.robot_body_contacts.tolist() == [1, 1]
    assert record.closest_approach < record.bound
    assert record.deepest_body == pytest.approx(CONFIG.robot_diameter - record.closest_approach)
    assert record.wall_contacts == 0


def test_a_bump_into_a_shelf_counts_as_a_wall_contact_and_a_restart_clears_the_record():
    grid = resolve_layout("aisles")
    start = next((r, c) for r, c in zip(*np.nonzero(grid.reachable_mask), strict=True)
                 if c + 1 < grid.cols and grid.shelf_mask[r, c + 1])  # fmt: skip
    world = BatchedPhysicsWorld(grid, CONFIG, [start], safety=True)
    cell, _ = world.move(np.array([(start[0], start[1] + 1)]))
    assert tuple(cell[0]) == tuple(start)  # the shelf stopped it
    record = world.safety
    assert record.wall_contacts == 1
    assert record.robot_wall_contacts.tolist() == [1]
    assert COLLISION_SLOP < record.deepest_wall < 0.1  # PENETRATION_TOLERANCE
    assert record.closest_approach == np.inf  # no other body
    world.restart([0], np.array([start]))
    assert record.wall_contacts == 0
    assert record.steps == 0


def test_the_summary_is_json_and_pairs_in_two_regions_within_a_diameter_are_split_contacts():
    record = SafetyRecord(3, WarehouseGrid(3, 3), CONFIG)
    path = np.array([[[0.5, 0.5], [1.0, 0.5], [2.5, 2.5]]])  # (x, y) [m], 1 m cells
    record.observe(path, np.zeros((3, 2)), 1.0, np.zeros(3, dtype=np.int64), np.array([0, 1, 0]))
    assert record.split_contacts == 1
    assert record.body_contacts == 1
    summary = json.loads(json.dumps(record.summary()))
    assert summary["closest_approach"] == 0.5
    assert summary["closest_approach_bound"] == CONFIG.robot_diameter - COLLISION_SLOP
    assert summary["split_contacts"] == 1
    assert summary["physics_steps_measured"] == 1
    assert SafetyRecord(1, WarehouseGrid(2, 2), CONFIG).summary()["closest_approach"] is None
