"""The floor split into regions stepped in parallel: the bodies of a seed and a number of
threads are the same bits in every process, the one-space bits while no two bodies touch;
robots that may touch share a space; and the fleet keeps safe under random delays at
2,000 robots."""

import copy
import pickle
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import ROOT
from tests.physics.golden_bodies import TICK_SCENARIOS, digest, golden, run_ticks
from warehouse_phys.envs import async_fleet
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.physics import PhysicsConfig, regions
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.regions import MAX_THREADS, check_threads
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import warehouse

#: A Kiva-style warehouse with room for 2,000 robots drawn at random (6,395 free cells).
BIG_WAREHOUSE = warehouse(shelf_rows=16, blocks_per_row=10)

CONFIG = PhysicsConfig()


def test_three_threads_replay_a_golden_run_with_robots_changing_region(monkeypatch):
    moved = []
    regroup = regions.RegionRows.regroup

    def counted(self, *args, **kwargs):
        moved.append(regroup(self, *args, **kwargs))
        self.check_rows()  # the rows kept follow chipmunk's own order after every move
        return moved[-1]

    monkeypatch.setattr(regions.RegionRows, "regroup", counted)
    name, kwargs, ticks = TICK_SCENARIOS[1]  # turning robots
    actual = run_ticks(kwargs, ticks, physics_threads=3)
    assert sum(moved) > 50  # robots crossed between regions, many times
    assert actual["digests"].tobytes() == golden(name)["digests"].tobytes()


def _crowded_world(threads: int, turning: bool = False) -> BatchedPhysicsWorld:
    """Robots packed on the rows of a small floor, which the moves below drive into each
    other: bodies touch and push."""
    grid = WarehouseGrid(6, 12)
    cells = np.array([(r, c) for r in range(6) for c in range(12) if (r + c) % 2 == 0])
    headings = np.zeros(len(cells), dtype=np.int64) if turning else None
    return BatchedPhysicsWorld(grid, CONFIG, cells, np.zeros(len(cells), dtype=np.int64),
                               threads=threads, safety=True, headings=headings)  # fmt: skip


def _pushed_run(threads: int, moves: int = 40) -> bytes:
    """Every robot aimed at random neighbours (two robots often at one cell): the digest
    of every body after every move."""
    world = _crowded_world(threads)
    rng = np.random.default_rng(11)
    deltas = np.array([(0, -1), (1, 0), (0, 1), (-1, 0), (0, 0)])
    digests = []
    for _ in range(moves):
        aims = np.clip(world.cells + deltas[rng.integers(5, size=world.n_robots)], 0,
                       [world.grid.rows - 1, world.grid.cols - 1])  # fmt: skip
        world.move(aims)
        digests.append(digest(world.last_paths))
    assert world.safety.body_contacts > 0  # the bodies did touch
    assert world.safety.split_contacts == 0
    return b"".join(d.tobytes() for d in digests)


def test_bodies_that_touch_are_the_same_bits_for_a_thread_count_in_every_process():
    script = ("from tests.physics.test_regions import _pushed_run; import sys; "
              "sys.stdout.write(_pushed_run(2).hex())")  # fmt: skip
    here = _pushed_run(2)
    assert here == _pushed_run(2)  # and again in this process
    other = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True,
                           text=True, check=True).stdout  # fmt: skip
    assert bytes.fromhex(other) == here


def test_robots_that_may_touch_share_a_region_and_every_region_steps():
    world = _crowded_world(2)
    assert sorted(set(world._rows.region.tolist())) == [0, 1]
    centre = world._rows.edges[0]
    # Robots either side of the band edge, driven at each other: one region before the move.
    near = np.flatnonzero(np.abs(world.cells[:, 1] - centre + 0.5) < 1)
    aims = world.cells.copy()
    aims[near, 1] = np.where(world.cells[near, 1] < centre, centre, centre - 1)
    world.move(aims)
    for i in near:
        for j in near:
            if np.abs(world._move_starts[i] - world._move_starts[j]).sum() <= 2:
                assert world._rows.region[i] == world._rows.region[j]


@pytest.mark.parametrize("turning", [False, True])
def test_a_copy_or_an_unpickled_world_of_regions_moves_as_the_original(turning):
    world = _crowded_world(2, turning)
    world.move(world.cells)
    twins = [copy.deepcopy(world), pickle.loads(pickle.dumps(world))]
    rng = np.random.default_rng(3)
    for _ in range(5):
        aims = np.clip(world.cells + rng.integers(-1, 2, size=(world.n_robots, 2)) * [0, 1], 0,
                       [world.grid.rows - 1, world.grid.cols - 1])  # fmt: skip
        for each in (world, *twins):
            each.move(aims)
        for twin in twins:
            assert twin.last_paths.tobytes() == world.last_paths.tobytes()
    for twin in twins:
        twin._rows.check_rows()


@pytest.mark.parametrize(
    ("threads", "error", "message"),
    [
        (True, TypeError, "threads must be a whole number, got True"),
        (2.0, TypeError, "threads must be a whole number, got 2.0"),
        (0, ValueError, f"threads must be from 1 to {MAX_THREADS}, got 0"),
        (MAX_THREADS + 1, ValueError, f"got {MAX_THREADS + 1}"),
        (10**400, ValueError, "got an integer of 1329 bits"),
    ],
)
def test_a_thread_count_out_of_range_is_refused_by_name(threads, error, message):
    with pytest.raises(error, match=message):
        check_threads(threads)
    with pytest.raises(error, match=message):
        BatchedPhysicsWorld(WarehouseGrid(3, 3), CONFIG, [(0, 0)], threads=threads)


@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), p_delay=st.sampled_from([0.005, 0.02, 0.05]),
       threads=st.sampled_from([2, 3]))  # fmt: skip
def test_two_thousand_bodies_keep_safe_under_random_delays_in_regions(seed, p_delay, threads):
    delays = DelayConfig(seed=seed % 1000, min_delay=1, max_delay=20, event_model="bernoulli",
                         p_delay=p_delay, duration_model="uniform")  # fmt: skip
    env = async_fleet.parallel_env(layout=BIG_WAREHOUSE, num_robots=2_000,
                                   physics=True, ticks_per_move=3, delays=delays, max_cycles=24,
                                   physics_threads=threads, seed=seed % 7)  # fmt: skip
    env.reset_arrays(seed=seed)
    go = np.ones(env.num_robots, dtype=np.int64)
    while env.agents:
        env.step_arrays(go)
    record = env.safety
    assert record.steps == 24 * env.tick_steps
    assert record.body_contacts == record.wall_contacts == record.split_contacts == 0
    assert record.closest_approach >= record.bound
    assert len(set(env.world._rows.region.tolist())) == threads
