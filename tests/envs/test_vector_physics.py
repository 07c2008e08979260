"""The physics-backed vector environment: what only it does (what both native vector envs
do is in test_vector_shared.py)."""

import gymnasium as gym
import numpy as np
import pytest

from tests.envs.vector_kinds import GRID_ID, PHYS_ID, assert_same_steps
from tests.memory import CAN_MEASURE, growth_per_reset
from warehouse_phys.envs.vector import WarehouseGridVectorEnv
from warehouse_phys.envs.vector_physics import WarehousePhysicsVectorEnv


# ---------------------------------------------------------------- the grid twin
def test_the_grid_vector_env_gives_the_same_transitions():
    grid_envs = gym.make_vec(GRID_ID, num_envs=32, max_episode_steps=15)
    phys_envs = gym.make_vec(PHYS_ID, num_envs=32, max_episode_steps=15)
    assert isinstance(grid_envs, WarehouseGridVectorEnv)
    rng = np.random.default_rng(4)
    a, b = grid_envs.reset(seed=9), phys_envs.reset(seed=9)
    assert np.array_equal(a[0], b[0])
    for _ in range(120):
        actions = rng.integers(4, size=32)
        assert_same_steps(grid_envs.step(actions), phys_envs.step(actions), "optimal_steps")


# ----------------------------------------------------------- paths, seeds, memory
def test_paths_need_recording_and_a_reset():
    envs = WarehousePhysicsVectorEnv(num_envs=2, record_path=True)
    with pytest.raises(gym.error.ResetNeeded):
        envs.last_move_paths  # noqa: B018 - the property raises
    plain = WarehousePhysicsVectorEnv(num_envs=2)
    plain.reset(seed=0)
    with pytest.raises(RuntimeError, match="record_path=True"):
        plain.last_move_paths  # noqa: B018


def test_a_refused_seed_keeps_the_world():
    envs = gym.make_vec(PHYS_ID, num_envs=2)
    envs.reset(seed=0)
    with pytest.raises(gym.error.Error, match="Seed must be greater or equal to zero"):
        envs.reset(seed=-1)
    assert envs.unwrapped.world is not None
    envs.step(np.array([2, 1]))  # the world it had


@pytest.mark.skipif(not CAN_MEASURE, reason="resident memory is read from Linux's /proc")
def test_a_reset_restarts_the_world_and_holds_no_more_memory():
    envs = gym.make_vec(PHYS_ID, num_envs=16)
    envs.reset(seed=0)
    world = envs.unwrapped.world
    envs.step(np.full(16, 2))
    envs.reset(seed=1)
    assert envs.unwrapped.world is world  # restarted, not rebuilt
    # Each rebuilt world used to keep a few kilobytes of chipmunk's arrays for good.
    assert growth_per_reset(lambda seed: envs.reset(seed=seed), 2000) < 100
