"""Recorded episodes: the same steps in both worlds, smooth frames in the physics one."""

import gymnasium as gym
import numpy as np
import pytest

import warehouse_phys
from tests.drawing.test_render import robot_centre
from warehouse_phys import SNAP_ERROR_BOUND, Action
from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_evaluation import random_fleet_policy, shortest_path_policy
from warehouse_phys.viz.recording import (
    record_episode,
    record_fleet_episode,
    sample_fleet_gaps,
    sample_snap_errors,
)

GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID
STEPS_PER_MOVE = 15  # 0.25 s moves of 1/60 s steps: the defaults


def scripted(actions):
    """A policy that plays ``actions`` in order, whatever it observes."""
    queue = list(actions)
    return lambda obs: queue.pop(0)


def record(env_id, actions, seed=0, **kwargs):
    env = gym.make(env_id, render_mode="rgb_array")
    return record_episode(env, scripted(actions), seed=seed, **kwargs)


# Seed 0 puts the package on (3, 3): six moves, one of them into the top wall.
ROUTE = [Action.UP, Action.RIGHT, Action.DOWN, Action.RIGHT, Action.DOWN, Action.RIGHT, Action.DOWN]


def test_both_worlds_record_the_same_episode_and_the_same_frames_after_each_step():
    grid = record(GRID_ID, ROUTE)
    phys = record(PHYS_ID, ROUTE)
    assert grid.target == phys.target == (3, 3)
    assert grid.steps == phys.steps == 7
    assert (grid.terminated, grid.truncated) == (phys.terminated, phys.truncated) == (True, False)
    assert np.array_equal(grid.observations, phys.observations)
    assert grid.observations.dtype == np.int64
    assert grid.observations.shape == (8, 4)
    assert grid.actions.tolist() == [int(a) for a in ROUTE]
    assert grid.rewards.tolist() == phys.rewards.tolist() == [0.0] * 6 + [1.0]
    assert grid.cells.tolist()[:3] == [[0, 0], [0, 0], [0, 1]]  # UP bumps into the wall
    # After each step both worlds stand on the same cell and draw the same picture.
    assert len(grid.frames) == len(phys.frames) == 8
    for a, b in zip(grid.frames, phys.frames, strict=True):
        assert np.array_equal(a, b)


def test_the_grid_twin_jumps_and_the_physics_drives():
    grid = record(GRID_ID, ROUTE)
    phys = record(PHYS_ID, ROUTE)
    assert (grid.fps, phys.fps) == (4, 60)
    assert grid.motion_frames == grid.frames  # one frame per step: jumps
    assert len(phys.motion_frames) == 1 + 7 * STEPS_PER_MOVE
    # Every move ends on its step's frame, and in between the body is on its way.
    for step in range(1, 8):
        assert np.array_equal(phys.motion_frames[step * STEPS_PER_MOVE], phys.frames[step])
    middle = robot_centre(phys.motion_frames[STEPS_PER_MOVE + 7])  # half-way through RIGHT
    assert middle[0] == pytest.approx(0, abs=0.05)
    assert 0.2 < middle[1] < 0.8
    # Both animations last as long as the episode: seven quarter-second moves.
    assert grid.animation().duration == pytest.approx(0.5 + 8 / 4 + 1)
    assert phys.animation().duration == pytest.approx(0.5 + 106 / 60 + 1)


def test_paths_hold_the_body_at_every_physics_step():
    grid = record(GRID_ID, ROUTE)
    phys = record(PHYS_ID, ROUTE)
    assert np.array_equal(grid.path, grid.cells.astype(float))
    assert [p.shape for p in phys.move_paths] == [(STEPS_PER_MOVE, 2)] * 7
    assert phys.path.shape == (1 + 7 * STEPS_PER_MOVE, 2)
    ends = phys.path[STEPS_PER_MOVE::STEPS_PER_MOVE]
    # Each move ends within the snap bound of the cell the observation reports...
    distances = np.linalg.norm(ends - phys.cells[1:], axis=1)
    assert np.allclose(distances, phys.snap_errors)
    assert distances.max() < SNAP_ERROR_BOUND
    # ...and no step jumps: the body never moves more than a fifth of a cell per step.
    assert np.linalg.norm(np.diff(phys.path, axis=0), axis=1).max() < 0.2
    assert grid.snap_errors.tolist() == [0.0] * 7


def test_max_steps_stops_an_episode_that_does_not_end():
    run = record(PHYS_ID, [Action.UP] * 5, max_steps=5)
    assert run.steps == 5
    assert (run.terminated, run.truncated) == (False, False)
    assert run.cells.tolist() == [[0, 0]] * 6
    assert record(GRID_ID, [], max_steps=0).frames[0].shape == (4 * 64 + 24, 5 * 64, 3)


def test_the_time_limit_ends_a_recording_as_truncated():
    env = gym.make(GRID_ID, render_mode="rgb_array", max_episode_steps=3)
    run = record_episode(env, lambda obs: Action.UP, seed=0)
    assert (run.steps, run.terminated, run.truncated) == (3, False, True)


def test_the_same_seed_records_the_same_episode():
    a = record(PHYS_ID, ROUTE, seed=0)
    b = record(PHYS_ID, ROUTE, seed=0)
    assert np.array_equal(a.path, b.path)
    assert all(np.array_equal(x, y) for x, y in zip(a.motion_frames, b.motion_frames, strict=True))


def test_an_environment_without_frames_is_refused():
    with pytest.raises(ValueError, match="render_mode='rgb_array', not None"):
        record_episode(gym.make(GRID_ID), scripted(ROUTE), seed=0)
    with pytest.raises(ValueError, match="max_steps must be at least 0, got -1"):
        record(GRID_ID, ROUTE, max_steps=-1)


def test_snap_errors_of_many_moves_are_reproducible_and_bounded():
    env = gym.make(PHYS_ID)
    errors = sample_snap_errors(env, 600, seed=3)
    assert errors.shape == (600,)
    assert np.array_equal(errors, sample_snap_errors(env, 600, seed=3))
    assert not np.array_equal(errors, sample_snap_errors(env, 600, seed=4))
    assert errors.min() > 0
    assert errors.max() < SNAP_ERROR_BOUND
    assert sample_snap_errors(env, 0, seed=3).shape == (0,)


def test_snap_errors_need_the_physics_backed_environment():
    with pytest.raises(ValueError, match="warehouse-robot-v0 reports no snap_error"):
        sample_snap_errors(gym.make(GRID_ID), 10, seed=0)
    with pytest.raises(ValueError, match="moves must be at least 0, got -5"):
        sample_snap_errors(gym.make(PHYS_ID), -5, seed=0)


# --------------------------------------------------------------------- fleets
@pytest.mark.parametrize("physics", [False, True])
def test_the_recorded_episode_shows_the_fleet_moving(physics):
    env = fleet.parallel_env(num_robots=2, physics=physics, render_mode="rgb_array", cell_px=32)
    animation, delivered = record_fleet_episode(env, shortest_path_policy, seed=0, max_steps=6)
    frames_per_step = 15 if physics else 1  # every physics step, or one jump a step
    assert len(animation.frames) == 1 + 6 * frames_per_step or delivered == 2
    assert animation.fps == (60 if physics else 4)
    assert animation.frames[0].shape == (4 * 32 + 20, 5 * 32, 3)


def test_sampled_gaps_are_every_robots_closest_approach_and_need_the_physics():
    env = fleet.parallel_env(num_robots=4, physics=True, lifelong=True)
    gaps = sample_fleet_gaps(env, random_fleet_policy(1), 40, seed=0)
    assert gaps.shape == (4 * 40,)
    assert gaps.min() > -0.002  # never deeper than the collision slop
    again = sample_fleet_gaps(env, random_fleet_policy(1), 40, seed=0)
    assert np.array_equal(gaps, again)  # seeded: the same run
    with pytest.raises(ValueError, match="only the physics world"):
        sample_fleet_gaps(fleet.parallel_env(num_robots=2), random_fleet_policy(1), 5, seed=0)
    untracked = fleet.parallel_env(num_robots=2, physics=True, track_gaps=False)
    with pytest.raises(ValueError, match="does not measure min_gap: make it with track_gaps"):
        sample_fleet_gaps(untracked, random_fleet_policy(1), 5, seed=0)
