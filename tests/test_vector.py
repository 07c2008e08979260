"""The native vector environment, proven against the single grid environment."""

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.wrappers.vector import RecordEpisodeStatistics

import warehouse_phys
from warehouse_phys.batched import BatchedRules
from warehouse_phys.grid import WarehouseGrid
from warehouse_phys.layouts import resolve_layout
from warehouse_phys.vector import WarehouseGridVectorEnv

GRID_ID = warehouse_phys.GRID_ENV_ID
SHELVES = ["S..#...", ".#.#.#.", ".#...#P", "...#..."]
FLOORS = {
    "default": (GRID_ID, {}),
    "6x7": (GRID_ID, {"grid_rows": 6, "grid_cols": 7, "max_episode_steps": 40}),
    **{name: (warehouse_phys.preset_ids(name)[0], {}) for name in warehouse_phys.PRESETS},
    "shelves": (GRID_ID, {"layout": SHELVES, "max_episode_steps": 25}),
}


# ------------------------------------------------------------------ the rules
@pytest.mark.parametrize(
    "grid",
    [WarehouseGrid(4, 5), WarehouseGrid(3, 9), resolve_layout("maze"),
     WarehouseGrid.from_layout(SHELVES)],
    ids=["4x5", "3x9", "maze", "shelves"],
)  # fmt: skip
def test_batched_tables_are_the_grids_rules(grid):
    rules = BatchedRules(grid)
    cols = grid.cols
    for cell in grid.reachable:
        for action in range(4):
            to = grid.move(cell, action)
            assert rules.moves[(cell[0] * cols + cell[1]) * 4 + action] == to[0] * cols + to[1]
    assert [
        (r, c) for r, c in zip(rules.rows[rules.targets], rules.cols[rules.targets], strict=True)
    ] == [tuple(t) for t in grid.target_cells]
    table = rules.distance_table().reshape(len(rules.targets), -1)
    for slot, target in enumerate(grid.target_cells):
        for cell in grid.reachable:
            assert table[slot, cell[0] * cols + cell[1]] == grid.optimal_steps(cell, target)
        cells = np.array([c[0] * cols + c[1] for c in sorted(grid.reachable)])
        expected = [grid.optimal_steps(c, target) for c in sorted(grid.reachable)]
        targets = np.full(len(cells), rules.index(target))
        assert rules.optimal_steps(cells, targets).tolist() == expected


# ------------------------------------------------------------ make_vec and API
@pytest.mark.parametrize("name", list(FLOORS))
def test_make_vec_returns_the_native_vector_env(name):
    env_id, kwargs = FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=3, **kwargs)
    assert isinstance(envs, WarehouseGridVectorEnv)
    single = gym.make(env_id, **kwargs)
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.max_episode_steps == single.spec.max_episode_steps
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.observation_space.shape == (3, 4)
    obs, infos = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    assert infos["_optimal_steps"].all()


def test_gymnasiums_own_vectorisation_stays_available():
    envs = gym.make_vec(GRID_ID, num_envs=2, vectorization_mode="sync")
    assert isinstance(envs, SyncVectorEnv)


# --------------------------------------------------------------- the replay proof
def record_episodes(envs, n_steps, seed):
    """Run random actions; return every sub-environment's episodes as
    (target, reset info, [(action, obs, reward, terminated, truncated, optimal_steps)])."""
    rng = np.random.default_rng(seed)
    obs, infos = envs.reset(seed=seed)
    episodes = [[] for _ in range(envs.num_envs)]
    current = [(tuple(o[2:]), int(i), []) for o, i in zip(obs, infos["optimal_steps"], strict=True)]
    restarting = np.zeros(envs.num_envs, dtype=bool)
    for _ in range(n_steps):
        actions = rng.integers(4, size=envs.num_envs)
        obs, rewards, terminated, truncated, infos = envs.step(actions)
        assert infos["_optimal_steps"].all()
        for i in range(envs.num_envs):
            if restarting[i]:  # this step started a new episode and ignored the action
                assert (rewards[i], terminated[i], truncated[i]) == (0.0, False, False)
                episodes[i].append(current[i])
                current[i] = (tuple(obs[i, 2:]), int(infos["optimal_steps"][i]), [])
            else:
                current[i][2].append((int(actions[i]), obs[i].copy(), rewards[i], terminated[i],
                                      truncated[i], int(infos["optimal_steps"][i])))  # fmt: skip
        restarting = terminated | truncated
    for i in range(envs.num_envs):
        episodes[i].append(current[i])
    return episodes


def replay(env_id, kwargs, episodes):
    env = gym.make(env_id, **kwargs)
    steps = 0
    for per_env in episodes:
        for target, optimal, transitions in per_env:
            obs, info = env.reset(options={"target": target})
            assert tuple(obs[2:]) == target
            assert tuple(obs[:2]) == tuple(env.unwrapped.grid.start)
            assert info["optimal_steps"] == optimal
            for action, v_obs, v_reward, v_term, v_trunc, v_optimal in transitions:
                obs, reward, terminated, truncated, info = env.step(action)
                assert np.array_equal(obs, v_obs)
                assert (reward, terminated, truncated) == (v_reward, v_term, v_trunc)
                assert info["optimal_steps"] == v_optimal
                steps += 1
    return steps


@pytest.mark.slow
@pytest.mark.parametrize("num_envs", [1, 7, 64])
@pytest.mark.parametrize("name", list(FLOORS))
def test_every_sub_environment_replays_step_for_step_in_a_single_env(name, num_envs):
    env_id, kwargs = FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=num_envs, **kwargs)
    n_steps = {1: 2000, 7: 1000, 64: 200}[num_envs]
    episodes = record_episodes(envs, n_steps, seed=num_envs)
    replayed = replay(env_id, kwargs, episodes)
    restarts = sum(len(per_env) - 1 for per_env in episodes)
    assert replayed + restarts == n_steps * num_envs
    if name in ("6x7", "shelves", "default"):
        assert restarts > 0  # the autoreset step was exercised


# ---------------------------------------------------------------------- targets
def chi_square_uniform(counts):
    """The chi-square statistic of ``counts`` against a uniform distribution, and its
    bound: mean + 6 standard deviations of the statistic under uniformity."""
    counts = np.asarray(counts, dtype=float)
    expected = counts.sum() / len(counts)
    statistic = ((counts - expected) ** 2 / expected).sum()
    dof = len(counts) - 1
    return statistic, dof + 6 * np.sqrt(2 * dof)


@pytest.mark.parametrize("name", ["default", "maze", "depot", "aisles"])
def test_packages_are_drawn_uniformly_from_the_target_cells_never_on_the_start(name):
    env_id, kwargs = FLOORS[name]
    envs = gym.make_vec(env_id, num_envs=4096, **kwargs)
    grid = envs.unwrapped.grid
    index = {tuple(cell): i for i, cell in enumerate(grid.target_cells)}
    counts = np.zeros(len(index))
    for seed in range(12):
        obs, _ = envs.reset(seed=seed)
        for target in map(tuple, obs[:, 2:].tolist()):
            counts[index[target]] += 1  # a KeyError here: a package off the target cells
    assert tuple(grid.start) not in index
    statistic, bound = chi_square_uniform(counts)
    assert statistic < bound
    # The test has teeth: one cell drawn twice as often as its share fails it.
    biased = counts.copy()
    biased[0] *= 2
    assert chi_square_uniform(biased)[0] > bound


# ------------------------------------------------------------------ determinism
def trajectory_bytes(seed, num_envs=16, n_steps=300):
    envs = gym.make_vec(GRID_ID, num_envs=num_envs, grid_rows=5, grid_cols=6)
    rng = np.random.default_rng(99)
    out = [envs.reset(seed=seed)[0].tobytes()]
    for _ in range(n_steps):
        obs, rewards, terminated, truncated, infos = envs.step(rng.integers(4, size=num_envs))
        out += [obs.tobytes(), rewards.tobytes(), terminated.tobytes(), truncated.tobytes(),
                infos["optimal_steps"].tobytes()]  # fmt: skip
    return b"".join(out)


def test_the_same_seed_gives_the_same_everything_in_any_process(run_python):
    import hashlib

    first, second = trajectory_bytes(3), trajectory_bytes(3)
    assert first == second
    assert first != trajectory_bytes(4)
    script = (
        "import hashlib; from tests.test_vector import trajectory_bytes; "
        "print(hashlib.sha256(trajectory_bytes(3)).hexdigest())"
    )
    assert run_python(script).strip() == hashlib.sha256(first).hexdigest()


def test_copies_and_pickles_continue_bit_for_bit():
    envs = gym.make_vec(GRID_ID, num_envs=8)
    envs.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(30):
        envs.step(rng.integers(4, size=8))
    for duplicate in (copy.deepcopy(envs), pickle.loads(pickle.dumps(envs))):
        check = np.random.default_rng(5)
        original = copy.deepcopy(envs)
        for _ in range(100):
            actions = check.integers(4, size=8)
            a, b = original.step(actions), duplicate.step(actions)
            for x, y in zip(a[:4], b[:4], strict=True):
                assert np.array_equal(x, y)
            assert np.array_equal(a[4]["optimal_steps"], b[4]["optimal_steps"])


# -------------------------------------------------------------- reset and masks
def test_reset_mask_restarts_only_the_marked_floors():
    envs = gym.make_vec(GRID_ID, num_envs=4)
    obs, _ = envs.reset(seed=0)
    obs, *_ = envs.step(np.array([2, 2, 1, 1]))
    mask = np.array([True, False, True, False])
    new_obs, infos = envs.reset(options={"reset_mask": mask})
    assert np.array_equal(new_obs[~mask], obs[~mask])  # untouched
    assert (new_obs[mask, :2] == 0).all()  # back on the start
    assert np.array_equal(infos["_optimal_steps"], mask)
    assert (infos["optimal_steps"][mask] == new_obs[mask, 2:].sum(axis=1)).all()


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"reset_mask": [True, False]}, TypeError, "must be a numpy array of bools, got list"),
        ({"reset_mask": np.array([1, 0])}, TypeError, "numpy array of bools, got ndarray of int64"),
        ({"reset_mask": np.array([True])}, ValueError, r"must have shape \(2,\), got \(1,\)"),
        ({"reset_mask": np.array([False, False])}, ValueError, "at least one sub-environment"),
        ({"target": (1, 1)}, ValueError, r"unknown reset option\(s\) 'target'"),
        (5, TypeError, "reset options must be a dict or None, got int"),
    ],
)
def test_bad_reset_options_are_refused_and_change_nothing(options, error, message):
    envs = gym.make_vec(GRID_ID, num_envs=2)
    obs, _ = envs.reset(seed=0)
    state = envs.unwrapped.np_random.bit_generator.state
    with pytest.raises(error, match=message):
        envs.reset(seed=5, options=options)
    assert envs.unwrapped.np_random.bit_generator.state == state
    assert np.array_equal(envs.step(np.zeros(2, dtype=int))[0][:, 2:], obs[:, 2:])


@pytest.mark.parametrize(
    ("actions", "error", "message"),
    [
        (np.array([0, 1, 2]), ValueError, r"must have shape \(2,\), one per sub-environment"),
        (np.array([0.0, 1.0]), TypeError, "actions must be integers in 0..3 .* got dtype float64"),
        (np.array([True, False]), TypeError, "got dtype bool"),
        (np.array([0, 4]), ValueError, "sub-environment 1 got 4"),
        (np.array([-1, -2]), ValueError, r"sub-environment 0 got -1 \(and 1 more\)"),
        (np.array([2, 300], dtype=np.uint16), ValueError, "sub-environment 1 got 300"),
        (5, ValueError, r"actions must have shape \(2,\)"),
        (np.array([0, 4], dtype=">i8"), ValueError, "sub-environment 1 got 4"),
        (np.array([1, 2], dtype="m8"), TypeError, "got dtype timedelta64"),
        ([1, [2, 3]], ValueError,
         r"^actions must be an array of shape \(2,\) of integers in 0..3; numpy cannot make an "
         r"array of this list: setting an array element with a sequence"),
        ([1, np.ma.masked], ValueError, "sub-environment 1's is masked"),
        (np.ma.masked_array([1, 2], mask=[1, 0]), ValueError, "sub-environment 0's is masked"),
    ],
)  # fmt: skip
def test_invalid_actions_are_refused_and_change_nothing(actions, error, message):
    envs = gym.make_vec(GRID_ID, num_envs=2)
    obs, _ = envs.reset(seed=0)
    with pytest.raises(error, match=message) as caught:
        envs.step(actions)
    assert "\n" not in str(caught.value)
    again, *_ = envs.step(np.array([3, 0]))  # into the walls: nothing moves
    assert np.array_equal(again, obs)
    assert envs.unwrapped._steps.tolist() == [1, 1]


def test_stepping_before_reset_is_refused():
    envs = gym.make_vec(GRID_ID, num_envs=2)
    with pytest.raises(gym.error.ResetNeeded):
        envs.step(np.zeros(2, dtype=int))


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"num_envs": 0}, ValueError, "num_envs must be 1 to"),
        ({"num_envs": 2.0}, TypeError, "num_envs must be an integer"),
        ({"num_envs": 2, "max_episode_steps": 0}, ValueError, "max_episode_steps must be at"),
        ({"num_envs": 2, "render_mode": "human"}, ValueError, "render_mode must be None or one of"),
        ({"num_envs": 2, "grid_rows": 600}, ValueError, "grid_rows must be at most 512"),
        ({"num_envs": np.timedelta64(2)}, TypeError, "num_envs must be an integer"),
        ({"num_envs": 2, "max_episode_steps": np.timedelta64(9)}, TypeError,
         "max_episode_steps must be an integer"),
        ({"num_envs": 2, "grid_cols": np.timedelta64(3)}, TypeError,
         "grid_cols must be an integer"),
        ({"num_envs": 2, "cell_px": np.timedelta64(3)}, TypeError, "cell_px must be an integer"),
    ],
)  # fmt: skip
def test_bad_arguments_are_refused_by_name(kwargs, error, message):
    with pytest.raises(error, match=message):
        WarehouseGridVectorEnv(**kwargs)


# ------------------------------------------------------------- wrappers, frames
def test_record_episode_statistics_counts_the_episodes():
    envs = RecordEpisodeStatistics(gym.make_vec(GRID_ID, num_envs=16))
    envs.reset(seed=0)
    rng = np.random.default_rng(1)
    lengths, returns = [], []
    for _ in range(400):
        *_, infos = envs.step(rng.integers(4, size=16))
        if "episode" in infos:
            done = infos["_episode"]
            lengths += infos["episode"]["l"][done].tolist()
            returns += infos["episode"]["r"][done].tolist()
    assert len(lengths) > 50
    assert set(returns) <= {0.0, 1.0}
    assert max(lengths) <= 200


def test_rgb_array_frames_are_the_single_environments():
    envs = gym.make_vec(GRID_ID, num_envs=3, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    obs, _ = envs.reset(seed=2)
    obs, *_ = envs.step(np.array([2, 1, 2]))
    frames = envs.render()
    assert len(frames) == 3
    single = gym.make(GRID_ID, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    for i, action in enumerate([2, 1, 2]):
        single.reset(options={"target": tuple(obs[i, 2:])})
        single.step(action)
        assert np.array_equal(frames[i], single.render())
    ansi = gym.make_vec(GRID_ID, num_envs=2, render_mode="ansi")
    ansi.reset(seed=0)
    assert all(frame.count("R") == 1 for frame in ansi.render())


def test_returned_arrays_are_never_reused():
    envs = gym.make_vec(GRID_ID, num_envs=4)
    first, infos = envs.reset(seed=0)
    kept = first.copy(), infos["optimal_steps"].copy()
    second = envs.step(np.array([2, 1, 2, 1]))
    envs.step(np.array([2, 1, 2, 1]))
    assert np.array_equal(first, kept[0])
    assert np.array_equal(infos["optimal_steps"], kept[1])
    assert not np.shares_memory(second[0], envs.step(np.zeros(4, dtype=int))[0])


@pytest.mark.parametrize("dtype", [np.int8, np.uint8, np.int32, np.uint32, np.uint64, np.int64])
def test_actions_of_any_integer_dtype_move_alike(dtype):
    envs = gym.make_vec(GRID_ID, num_envs=3)
    envs.reset(seed=0)
    obs, *_ = envs.step(np.array([2, 1, 0], dtype=dtype))
    assert obs[:, :2].tolist() == [[0, 1], [1, 0], [0, 0]]


@pytest.mark.parametrize("dtype", [">i8", ">u2", ">i4"])
def test_big_endian_actions_move_as_native_ones(dtype):
    envs = gym.make_vec(GRID_ID, num_envs=3)
    envs.reset(seed=0)
    obs, *_ = envs.step(np.array([2, 1, 0], dtype=dtype))
    assert obs[:, :2].tolist() == [[0, 1], [1, 0], [0, 0]]


# ------------------------------------------------------- deep-RL options (issue 23)
def replay_in_single_envs(env_id, num_envs, steps, **kwargs):
    """Step a native vector env with random actions and replay every floor's episodes
    in a single environment made with the same keywords; they must agree step by step."""
    envs = gym.make_vec(env_id, num_envs=num_envs, **kwargs)
    singles = [gym.make(env_id, **kwargs) for _ in range(num_envs)]
    # The same floors, read as cells (for the packages of the one-hot floors).
    cells = gym.make_vec(env_id, num_envs=num_envs, **{**kwargs, "observation": "cells"})
    obs, _ = envs.reset(seed=5)
    cell_obs, _ = cells.reset(seed=5)
    for i, single in enumerate(singles):
        first, _ = single.reset(options={"target": tuple(cell_obs[i, 2:])})
        np.testing.assert_array_equal(first, obs[i])
    restart = np.zeros(num_envs, dtype=bool)
    ended = np.zeros(num_envs, dtype=np.int64)
    rng = np.random.default_rng(1)
    for _ in range(steps):
        actions = rng.integers(4, size=num_envs)
        obs, rewards, terminated, truncated, _ = envs.step(actions)
        cell_obs = cells.step(actions)[0]
        for i, single in enumerate(singles):
            if restart[i]:
                expected = single.reset(options={"target": tuple(cell_obs[i, 2:])})[0]
                assert (rewards[i], terminated[i], truncated[i]) == (0.0, False, False)
            else:
                expected, reward, term, trunc, _ = single.step(int(actions[i]))
                assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
            np.testing.assert_array_equal(obs[i], expected)
        restart = terminated | truncated
        ended += restart
    assert ended.sum() >= num_envs  # episodes ended and restarted along the way
    return envs


@pytest.mark.parametrize("observation", ["cells", "onehot"])
@pytest.mark.parametrize("env_id", [GRID_ID, warehouse_phys.PHYSICS_ENV_ID], ids=["grid", "phys"])
def test_penalties_and_onehot_follow_the_single_environment(env_id, observation):
    kwargs = {"step_penalty": 0.01, "bump_penalty": 0.25, "max_episode_steps": 12}
    envs = replay_in_single_envs(env_id, 4, 60, observation=observation, **kwargs)
    width = 2 * 4 + 2 * 5
    if observation == "onehot":
        assert envs.single_observation_space == gym.spaces.Box(0, 1, (width,), np.float32)
        assert envs.observation_space.shape == (4, width)


def test_penalties_are_checked_by_name():
    for keyword in ("step_penalty", "bump_penalty"):
        with pytest.raises(ValueError, match=keyword):
            gym.make_vec(GRID_ID, num_envs=2, **{keyword: -1.0})
        with pytest.raises(TypeError, match=keyword):
            gym.make_vec(GRID_ID, num_envs=2, **{keyword: "1"})
    with pytest.raises(ValueError, match="observation must be one of"):
        gym.make_vec(GRID_ID, num_envs=2, observation="image")


def test_the_sb3_adapter_without_stable_baselines3_names_the_extra(monkeypatch):
    import sys

    from warehouse_phys import sb3

    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    monkeypatch.setitem(sys.modules, "stable_baselines3.common", None)
    with pytest.raises(ImportError, match=r'pip install "warehouse_phys\[sb3\]"'):
        sb3.vec_env(GRID_ID, num_envs=2)
