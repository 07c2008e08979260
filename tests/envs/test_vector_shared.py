"""What both native vector envs promise, the grid twin's and the physics twin's, each proven
against its single environment. What only one twin does is tested in its own file."""

import copy
import hashlib
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from tests.envs.vector_kinds import (
    KINDS,
    PHYS,
    TOLERANCE,
    assert_same_steps,
    record_episodes,
    replay,
    trajectory_bytes,
)

each_kind = pytest.mark.parametrize("kind", KINDS.values(), ids=list(KINDS))


def floors_of_each_kind():
    return [
        pytest.param(kind, name, id=f"{kind.name}-{name}")
        for kind in KINDS.values()
        for name in kind.floors
    ]


# ------------------------------------------------------------ make_vec and API
@pytest.mark.parametrize(("kind", "name"), floors_of_each_kind())
def test_make_vec_returns_the_native_vector_env(kind, name):
    env_id, kwargs = kind.floors[name]
    envs = gym.make_vec(env_id, num_envs=3, **kwargs)
    assert isinstance(envs, kind.vector_class)
    single = gym.make(env_id, **kwargs)
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.max_episode_steps == single.spec.max_episode_steps
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.observation_space.shape == (3, 4)
    obs, infos = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    for key in kind.info_keys:
        assert infos[f"_{key}"].all()
    if kind.physics:
        assert (infos["snap_error"] == 0).all()


# --------------------------------------------------------------- the replay proof
def replay_cases():
    # The grid's replays (up to 2000 steps) are marked slow; the physics twin's are shorter.
    return [
        pytest.param(kind, name, num_envs, id=f"{kind.name}-{name}-{num_envs}",
                     marks=() if kind.physics else pytest.mark.slow)
        for kind in KINDS.values()
        for name in kind.floors
        for num_envs in kind.replay_steps
    ]  # fmt: skip


@pytest.mark.parametrize(("kind", "name", "num_envs"), replay_cases())
def test_every_sub_environment_replays_step_for_step_in_a_single_env(kind, name, num_envs):
    env_id, kwargs = kind.floors[name]
    envs = gym.make_vec(env_id, num_envs=num_envs, **kind.record, **kwargs)
    n_steps = kind.replay_steps[num_envs]
    episodes = record_episodes(envs, n_steps, seed=num_envs)
    replayed, worst = replay(kind, env_id, kwargs, episodes)
    restarts = sum(len(per_env) - 1 for per_env in episodes)
    assert replayed + restarts == n_steps * num_envs
    assert worst < TOLERANCE
    if num_envs == 1:
        assert worst == 0.0  # the first floor's robot moves as the single env's: bit for bit
    if name in kind.autoreset_floors:
        assert restarts > 0  # the autoreset step was exercised


# ------------------------------------------------------------------ determinism
def test_the_same_seed_gives_the_same_everything_in_any_process(run_python):
    """Both kinds, in one fresh process (one interpreter to start, not two), in the other
    order there, so that neither case follows the other on both sides."""
    expected = []
    for name in KINDS:
        first, second = trajectory_bytes(name, 3), trajectory_bytes(name, 3)
        assert first == second, name
        assert first != trajectory_bytes(name, 4), name
        expected = [hashlib.sha256(first).hexdigest(), *expected]  # the other order
    script = (
        "import hashlib; from tests.envs.vector_kinds import trajectory_bytes\n"
        f"for name in {list(KINDS)[::-1]!r}:\n"
        "    print(hashlib.sha256(trajectory_bytes(name, 3)).hexdigest())\n"
    )
    assert run_python(script).split() == expected


@each_kind
def test_copies_and_pickles_continue_bit_for_bit(kind):
    num_envs, warm_up, compared, kwargs = kind.copies
    envs = gym.make_vec(kind.env_id, num_envs=num_envs, **kwargs)
    envs.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(warm_up):
        envs.step(rng.integers(4, size=num_envs))
    for duplicate in (copy.deepcopy(envs), pickle.loads(pickle.dumps(envs))):
        check = np.random.default_rng(5)
        original = copy.deepcopy(envs)
        for _ in range(compared):
            actions = check.integers(4, size=num_envs)
            assert_same_steps(original.step(actions), duplicate.step(actions), *kind.info_keys)
            if kind.physics:
                assert np.array_equal(original.last_move_paths, duplicate.last_move_paths)


# -------------------------------------------------------------- reset and masks
@each_kind
def test_reset_mask_restarts_only_the_marked_floors(kind):
    envs = gym.make_vec(kind.env_id, num_envs=4, **kind.record)
    envs.reset(seed=0)
    obs, *_ = envs.step(np.array([2, 2, 1, 1]))
    mask = np.array([True, False, True, False])
    new_obs, infos = envs.reset(options={"reset_mask": mask})
    assert np.array_equal(new_obs[~mask], obs[~mask])  # untouched
    assert (new_obs[mask, :2] == 0).all()  # back on the start
    for key in kind.info_keys:
        assert np.array_equal(infos[f"_{key}"], mask)
        assert (infos[key][~mask] == 0).all()
    assert (infos["optimal_steps"][mask] == new_obs[mask, 2:].sum(axis=1)).all()
    # The restarted robots move exactly as those of a new vector env.
    fresh = gym.make_vec(kind.env_id, num_envs=4, **kind.record)
    fresh.reset(seed=0)
    moved, *_ = envs.step(np.array([2, 0, 1, 0]))
    expected, *_ = fresh.step(np.array([2, 0, 1, 0]))
    assert np.array_equal(moved[mask, :2], expected[mask, :2])
    if kind.physics:
        assert np.array_equal(envs.last_move_paths[mask], fresh.last_move_paths[mask])


# ------------------------------------------------------------- arguments, frames
COMMON_BAD_ARGUMENTS = [
    ({"num_envs": 0}, ValueError, "num_envs must be 1 to"),
    ({"num_envs": 2.0}, TypeError, "num_envs must be an integer"),
    ({"max_episode_steps": 0}, ValueError, "max_episode_steps must be at"),
    ({"render_mode": "human"}, ValueError, "render_mode must be None or one of"),
    ({"grid_rows": 3000}, ValueError, "grid_rows must be at most 2048"),
    ({"num_envs": np.timedelta64(2)}, TypeError, "num_envs must be an integer"),
    ({"max_episode_steps": np.timedelta64(9)}, TypeError, "max_episode_steps must be an integer"),
    ({"grid_cols": np.timedelta64(3)}, TypeError, "grid_cols must be an integer"),
    ({"cell_px": np.timedelta64(3)}, TypeError, "cell_px must be an integer"),
]
PHYSICS_BAD_ARGUMENTS = [
    ({"robot_radius": 0.6}, ValueError, "robot_radius 0.6 m must be less than half"),
    ({"max_force": 1.0}, ValueError, "with these settings"),
    ({"mass": 3.0}, TypeError, r"unknown argument\(s\) 'mass'; the physical parameters"),
    ({"dt": "fast"}, TypeError, "dt must be a real number"),
    ({"record_path": 1}, TypeError, "record_path must be a bool or None"),
    ({"num_envs": 2**16 + 1}, ValueError, "num_envs must be 1 to 65536, got 65537"),
]


def bad_argument_cases():
    return [
        pytest.param(kind, *case, id=f"{kind.name}-{'-'.join(case[0])}-{number}")
        for kind in KINDS.values()
        for number, case in enumerate(COMMON_BAD_ARGUMENTS)
    ] + [
        pytest.param(PHYS, *case, id=f"phys-{'-'.join(case[0])}") for case in PHYSICS_BAD_ARGUMENTS
    ]


@pytest.mark.parametrize(("kind", "kwargs", "error", "message"), bad_argument_cases())
def test_bad_arguments_are_refused_by_name(kind, kwargs, error, message):
    kwargs = {"num_envs": 2, **kwargs}
    with pytest.raises(error, match=message):
        kind.vector_class(**kwargs)


@each_kind
def test_rgb_array_frames_are_the_single_environments(kind):
    envs = gym.make_vec(kind.env_id, num_envs=3, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    if kind.physics:
        assert envs.record_path  # the frames draw the paths
    obs, _ = envs.reset(seed=2)
    obs, *_ = envs.step(np.array([2, 1, 2]))
    frames = envs.render()
    assert len(frames) == 3
    if kind.physics:
        assert envs.last_move_paths.shape == (3, 15, 2)
    single = gym.make(kind.env_id, render_mode="rgb_array", grid_rows=3, grid_cols=4)
    for i, action in enumerate([2, 1, 2]):
        single.reset(options={"target": tuple(obs[i, 2:])})
        single.step(action)
        assert np.array_equal(frames[i], single.render())
    ansi = gym.make_vec(kind.env_id, num_envs=2, render_mode="ansi")
    ansi.reset(seed=0)
    assert all(frame.count("R") == 1 for frame in ansi.render())


# ------------------------------------------------------------ actions' dtypes
@pytest.mark.parametrize(
    "dtype",
    [np.int8, np.uint8, np.int32, np.uint32, np.uint64, np.int64, ">i8", ">u2", ">i4"],
    ids=lambda dtype: dtype if isinstance(dtype, str) else dtype.__name__,
)
@each_kind
def test_actions_of_any_integer_dtype_and_byte_order_move_as_native_ones(kind, dtype):
    native, other = (gym.make_vec(kind.env_id, num_envs=3) for _ in range(2))
    native.reset(seed=4)
    other.reset(seed=4)
    for actions in ([2, 1, 0], [1, 2, 3], [2, 2, 1]):
        expected = native.step(np.array(actions))
        got = other.step(np.array(actions, dtype=dtype))
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_equal(a, b)
        if actions == [2, 1, 0]:  # the first moves, from the start
            assert got[0][:, :2].tolist() == [[0, 1], [1, 0], [0, 0]]


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
@each_kind
def test_penalties_and_onehot_follow_the_single_environment(kind, observation):
    kwargs = {"step_penalty": 0.01, "bump_penalty": 0.25, "max_episode_steps": 12}
    envs = replay_in_single_envs(kind.env_id, 4, 60, observation=observation, **kwargs)
    width = 2 * 4 + 2 * 5
    if observation == "onehot":
        assert envs.single_observation_space == gym.spaces.Box(0, 1, (width,), np.float32)
        assert envs.observation_space.shape == (4, width)


# ------------------------------------------------------ argument checks (issue 32)
@each_kind
def test_lists_of_mixed_integer_scalars_are_actions(kind):
    envs = gym.make_vec(kind.env_id, num_envs=5)
    twin = gym.make_vec(kind.env_id, num_envs=5)
    envs.reset(seed=3)
    twin.reset(seed=3)
    mixed = [np.int8(2), np.uint64(1), 0, np.uint8(3), np.array(1, dtype=">i2")]
    assert_same_steps(envs.step(mixed), twin.step(np.array([2, 1, 0, 3, 1])), *kind.info_keys)
    mixed = (np.int64(1), np.uint16(2), np.int32(2), 1, np.uint32(0))
    assert_same_steps(envs.step(mixed), twin.step(np.array([1, 2, 2, 1, 0])), *kind.info_keys)


@each_kind
@pytest.mark.parametrize(
    "value", [10**400, -(10**400), 10**5000], ids=["1e400", "-1e400", "1e5000"]
)
@pytest.mark.parametrize("keyword", ["step_penalty", "bump_penalty"])
def test_a_penalty_too_big_for_a_float_is_refused_by_name(kind, keyword, value):
    with pytest.raises(ValueError, match=f"^{keyword} must be a finite number >= 0, got a"):
        gym.make_vec(kind.env_id, num_envs=2, **{keyword: value})
    with pytest.raises(ValueError, match=r"^step_penalty \+ bump_penalty must be finite"):
        gym.make_vec(kind.env_id, num_envs=2, step_penalty=1e308, bump_penalty=1e308)


@each_kind
@pytest.mark.parametrize(
    ("keyword", "value"),
    [("num_envs", 10**5000), ("max_episode_steps", -(10**5000))],
    ids=["num_envs", "max_episode_steps"],
)
def test_counts_beyond_int64_are_refused_by_name_in_one_line(kind, keyword, value):
    with pytest.raises(ValueError, match=f"^{keyword} must be .*, got a.* integer of 16610 bits$"):
        kind.vector_class(**{"num_envs": 2, keyword: value})
