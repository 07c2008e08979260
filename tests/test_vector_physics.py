"""The physics-backed vector environment, proven against the single physics environment."""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import warehouse_phys
from tests.memory import CAN_MEASURE, growth_per_reset
from warehouse_phys import SNAP_ERROR_BOUND
from warehouse_phys.vector import WarehouseGridVectorEnv, WarehousePhysicsVectorEnv

PHYS_ID = warehouse_phys.PHYSICS_ENV_ID
FLOORS = {
    "default": (PHYS_ID, {"max_episode_steps": 12}),  # short: truncations and autoresets
    **{name: (warehouse_phys.preset_ids(name)[1], {}) for name in warehouse_phys.PRESETS},
}
#: Body positions may differ from the single environment's by no more than this [cells].
TOLERANCE = 1e-9


@pytest.mark.parametrize("name", list(FLOORS))
def test_make_vec_returns_the_native_physics_vector_env(name):
    env_id, kwargs = FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=3, **kwargs)
    assert isinstance(envs, WarehousePhysicsVectorEnv)
    single = gym.make(env_id, **kwargs)
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.max_episode_steps == single.spec.max_episode_steps
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, infos = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    assert infos["_optimal_steps"].all()
    assert infos["_snap_error"].all()
    assert (infos["snap_error"] == 0).all()


# --------------------------------------------------------------- the replay proof
def record_episodes(envs, n_steps, seed):
    """Random actions; every sub-environment's episodes as (target, reset info,
    [(action, obs, reward, terminated, truncated, optimal_steps, path)])."""
    rng = np.random.default_rng(seed)
    obs, infos = envs.reset(seed=seed)
    n = envs.num_envs
    episodes = [[] for _ in range(n)]
    current = [(tuple(o[2:]), int(i), []) for o, i in zip(obs, infos["optimal_steps"], strict=True)]
    restarting = np.zeros(n, dtype=bool)
    for _ in range(n_steps):
        actions = rng.integers(4, size=n)
        obs, rewards, terminated, truncated, infos = envs.step(actions)
        paths = envs.last_move_paths
        assert paths.shape == (n, envs.physics.steps_per_move, 2)
        assert infos["_snap_error"].all()
        assert (infos["snap_error"] < SNAP_ERROR_BOUND).all()
        for i in range(n):
            if restarting[i]:  # this step started a new episode and ignored the action
                assert (rewards[i], terminated[i], truncated[i]) == (0.0, False, False)
                assert infos["snap_error"][i] == 0.0
                assert (paths[i] == obs[i, :2]).all()  # it stood on the start
                episodes[i].append(current[i])
                current[i] = (tuple(obs[i, 2:]), int(infos["optimal_steps"][i]), [])
            else:
                current[i][2].append((int(actions[i]), obs[i].copy(), rewards[i], terminated[i],
                                      truncated[i], int(infos["optimal_steps"][i]),
                                      paths[i]))  # fmt: skip
        restarting = terminated | truncated
    for i in range(n):
        episodes[i].append(current[i])
    return episodes


def replay(env_id, kwargs, episodes):
    """Replay each episode in a single environment; the largest difference in position."""
    env = gym.make(env_id, record_path=True, **kwargs)
    worst = 0.0
    for per_env in episodes:
        for target, optimal, transitions in per_env:
            obs, info = env.reset(options={"target": target})
            assert tuple(obs[:2]) == tuple(env.unwrapped.grid.start)
            assert info["optimal_steps"] == optimal
            for action, v_obs, v_reward, v_term, v_trunc, v_optimal, v_path in transitions:
                obs, reward, terminated, truncated, info = env.step(action)
                assert np.array_equal(obs, v_obs)
                assert (reward, terminated, truncated) == (v_reward, v_term, v_trunc)
                assert info["optimal_steps"] == v_optimal
                worst = max(worst, np.abs(env.unwrapped.last_move_path - v_path).max())
    return worst


@pytest.mark.parametrize("num_envs", [1, 5, 64])
@pytest.mark.parametrize("name", list(FLOORS))
def test_every_sub_environment_replays_in_a_single_physics_env(name, num_envs):
    env_id, kwargs = FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=num_envs, record_path=True, **kwargs)
    n_steps = {1: 300, 5: 120, 64: 40}[num_envs]
    episodes = record_episodes(envs, n_steps, seed=num_envs)
    worst = replay(env_id, kwargs, episodes)
    assert worst < TOLERANCE
    if num_envs == 1:
        assert worst == 0.0  # the first floor sits where the single env's does: bit for bit
    if name == "default":
        assert sum(len(per_env) - 1 for per_env in episodes) > 0  # autoresets were exercised


def test_the_grid_vector_env_gives_the_same_transitions():
    grid_envs = gym.make_vec(warehouse_phys.GRID_ENV_ID, num_envs=32, max_episode_steps=15)
    phys_envs = gym.make_vec(PHYS_ID, num_envs=32, max_episode_steps=15)
    assert isinstance(grid_envs, WarehouseGridVectorEnv)
    rng = np.random.default_rng(4)
    a, b = grid_envs.reset(seed=9), phys_envs.reset(seed=9)
    assert np.array_equal(a[0], b[0])
    for _ in range(120):
        actions = rng.integers(4, size=32)
        a, b = grid_envs.step(actions), phys_envs.step(actions)
        for x, y in zip(a[:4], b[:4], strict=True):
            assert np.array_equal(x, y)
        assert np.array_equal(a[4]["optimal_steps"], b[4]["optimal_steps"])


# ------------------------------------------------------------------ determinism
def trajectory_bytes(seed, num_envs=12, n_steps=60):
    envs = gym.make_vec(PHYS_ID, num_envs=num_envs, record_path=True, max_episode_steps=20)
    rng = np.random.default_rng(99)
    out = [envs.reset(seed=seed)[0].tobytes()]
    for _ in range(n_steps):
        obs, rewards, terminated, truncated, infos = envs.step(rng.integers(4, size=num_envs))
        out += [obs.tobytes(), rewards.tobytes(), terminated.tobytes(), truncated.tobytes(),
                infos["snap_error"].tobytes(), envs.last_move_paths.tobytes()]  # fmt: skip
    return b"".join(out)


def test_the_same_seed_gives_bit_identical_paths_in_any_process(run_python):
    import hashlib

    first = trajectory_bytes(3)
    assert first == trajectory_bytes(3)
    assert first != trajectory_bytes(4)
    script = (
        "import hashlib; from tests.test_vector_physics import trajectory_bytes; "
        "print(hashlib.sha256(trajectory_bytes(3)).hexdigest())"
    )
    assert run_python(script).strip() == hashlib.sha256(first).hexdigest()


def test_copies_and_pickles_continue_bit_for_bit():
    envs = gym.make_vec(PHYS_ID, num_envs=6, record_path=True, max_episode_steps=10)
    envs.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(25):
        envs.step(rng.integers(4, size=6))
    for duplicate in (copy.deepcopy(envs), pickle.loads(pickle.dumps(envs))):
        check = np.random.default_rng(5)
        original = copy.deepcopy(envs)
        for _ in range(40):
            actions = check.integers(4, size=6)
            a, b = original.step(actions), duplicate.step(actions)
            for x, y in zip(a[:4], b[:4], strict=True):
                assert np.array_equal(x, y)
            assert np.array_equal(a[4]["snap_error"], b[4]["snap_error"])
            assert np.array_equal(original.last_move_paths, duplicate.last_move_paths)


# -------------------------------------------------------------- reset and masks
def test_reset_mask_restarts_only_the_marked_floors_on_fresh_robots():
    envs = gym.make_vec(PHYS_ID, num_envs=4, record_path=True)
    envs.reset(seed=0)
    obs, *_ = envs.step(np.array([2, 2, 1, 1]))
    mask = np.array([True, False, True, False])
    new_obs, infos = envs.reset(options={"reset_mask": mask})
    assert np.array_equal(new_obs[~mask], obs[~mask])
    assert (new_obs[mask, :2] == 0).all()
    for key in ("optimal_steps", "snap_error"):
        assert np.array_equal(infos[f"_{key}"], mask)
        assert (infos[key][~mask] == 0).all()
    # The restarted robots move exactly as those of a new vector env.
    fresh = gym.make_vec(PHYS_ID, num_envs=4, record_path=True)
    fresh.reset(seed=0)
    envs.step(np.array([2, 0, 1, 0]))
    fresh.step(np.array([2, 0, 1, 0]))
    assert np.array_equal(envs.last_move_paths[mask], fresh.last_move_paths[mask])


def test_rgb_array_frames_are_the_single_environments():
    envs = gym.make_vec(PHYS_ID, num_envs=3, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    assert envs.record_path
    obs, _ = envs.reset(seed=2)
    obs, *_ = envs.step(np.array([2, 1, 2]))
    frames = envs.render()
    assert envs.last_move_paths.shape == (3, 15, 2)
    single = gym.make(PHYS_ID, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    for i, action in enumerate([2, 1, 2]):
        single.reset(options={"target": tuple(obs[i, 2:])})
        single.step(action)
        assert np.array_equal(frames[i], single.render())


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"robot_radius": 0.6}, ValueError, "robot_radius 0.6 m must be less than half"),
        ({"max_force": 1.0}, ValueError, "with these settings"),
        ({"mass": 3.0}, TypeError, r"unknown argument\(s\) 'mass'; the physical parameters"),
        ({"dt": "fast"}, TypeError, "dt must be a real number"),
        ({"record_path": 1}, TypeError, "record_path must be a bool or None"),
        ({"num_envs": 0}, ValueError, "num_envs must be 1 to"),
        ({"num_envs": 2**16 + 1}, ValueError, "num_envs must be 1 to 65536, got 65537"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, error, message):
    kwargs = {"num_envs": 2, **kwargs}
    with pytest.raises(error, match=message):
        WarehousePhysicsVectorEnv(**kwargs)


def test_paths_need_recording_and_a_reset():
    envs = WarehousePhysicsVectorEnv(num_envs=2, record_path=True)
    with pytest.raises(gym.error.ResetNeeded):
        envs.last_move_paths  # noqa: B018 - the property raises
    plain = WarehousePhysicsVectorEnv(num_envs=2)
    plain.reset(seed=0)
    with pytest.raises(RuntimeError, match="record_path=True"):
        plain.last_move_paths  # noqa: B018


def test_big_endian_actions_move_as_native_ones():
    native, swapped = (gym.make_vec(PHYS_ID, num_envs=3) for _ in range(2))
    native.reset(seed=4)
    swapped.reset(seed=4)
    for actions in ([2, 1, 0], [1, 2, 3], [2, 2, 1]):
        expected = native.step(np.array(actions))
        got = swapped.step(np.array(actions, dtype=">i8"))
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_equal(a, b)


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
