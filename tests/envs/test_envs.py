"""Both environments as Gymnasium users meet them: rules, spaces, seeding, checker, bad input.

Every test that takes ``env_cls`` or ``env_id`` runs on the grid twin and on
the physics-backed environment; tests of the physics alone are in
``test_envs_physics.py``.
"""

import copy
import json
import math
import os
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import warehouse_phys
from warehouse_phys import Action, WarehouseGridEnv, WarehousePhysicsEnv

ENV_ID = warehouse_phys.GRID_ENV_ID
ENV_CLASSES = {
    warehouse_phys.GRID_ENV_ID: WarehouseGridEnv,
    warehouse_phys.PHYSICS_ENV_ID: WarehousePhysicsEnv,
}
DELTAS = {0: (0, -1), 1: (1, 0), 2: (0, 1), 3: (-1, 0)}  # the rule, written out independently


@pytest.fixture(params=list(ENV_CLASSES), ids=["grid", "phys"])
def env_id(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(params=list(ENV_CLASSES.values()), ids=["grid", "phys"])
def env_cls(request: pytest.FixtureRequest) -> type:
    return request.param


def rule_next(rows, cols, cell, action):
    row = min(max(cell[0] + DELTAS[action][0], 0), rows - 1)
    col = min(max(cell[1] + DELTAS[action][1], 0), cols - 1)
    return row, col


# ----------------------------------------------------------------------- rules
@pytest.mark.parametrize("rows", range(2, 7))
@pytest.mark.parametrize("cols", range(2, 8))
def test_every_state_and_action_follows_the_rule(rows, cols, env_cls):
    """Exhaustive: every (robot, target) pair of the grid and every action."""
    env = env_cls(grid_rows=rows, grid_cols=cols)
    targets = [(r, c) for r in range(1, rows) for c in range(1, cols)]
    cells = [(r, c) for r in range(rows) for c in range(cols)]
    for target in targets:
        for robot in cells:
            for action in range(4):
                if robot == target:
                    # The robot cannot start on the target: step onto it from a neighbour.
                    env.reset(options={"start": (target[0] - 1, target[1]), "target": target})
                    env.step(Action.DOWN)
                else:
                    env.reset(options={"start": robot, "target": target})
                obs, reward, terminated, truncated, info = env.step(action)
                expected = rule_next(rows, cols, robot, action)
                on_target = expected == target
                assert obs.tolist() == [*expected, *target], (robot, target, action)
                assert reward == (1.0 if on_target else 0.0)
                assert terminated is on_target
                assert truncated is False
                assert info["optimal_steps"] == abs(expected[0] - target[0]) + abs(
                    expected[1] - target[1]
                )


def test_reset_puts_robot_on_start_and_target_in_allowed_cells(env_cls):
    env = env_cls()
    for seed in range(200):
        obs, info = env.reset(seed=seed)
        assert obs[:2].tolist() == [0, 0]
        assert 1 <= obs[2] <= 3
        assert 1 <= obs[3] <= 4
        assert info["optimal_steps"] == int(obs[2] + obs[3])


def test_reward_and_termination_on_reaching_the_target(env_cls):
    env = env_cls()
    env.reset(options={"target": (1, 1)})
    obs, reward, terminated, _, info = env.step(Action.RIGHT)
    assert (obs.tolist(), reward, terminated, info["optimal_steps"]) == (
        [0, 1, 1, 1],
        0.0,
        False,
        1,
    )
    obs, reward, terminated, _, info = env.step(Action.DOWN)
    assert (obs.tolist(), reward, terminated, info["optimal_steps"]) == ([1, 1, 1, 1], 1.0, True, 0)
    assert isinstance(reward, float)


def test_move_off_the_floor_stays_and_counts_as_a_step(env_id):
    env = gym.make(env_id, max_episode_steps=3)
    env.reset(seed=0)
    for _ in range(2):
        obs, _, _, truncated, _ = env.step(Action.UP)
        assert obs[:2].tolist() == [0, 0]
        assert not truncated
    _, _, _, truncated, _ = env.step(Action.LEFT)
    assert truncated


# ------------------------------------------------------------------ target law
def chi2_critical(dof: int, z: float = 3.09) -> float:
    """Upper chi-square quantile (p ~ 0.001) by the Wilson-Hilferty approximation."""
    return dof * (1 - 2 / (9 * dof) + z * math.sqrt(2 / (9 * dof))) ** 3


@pytest.mark.parametrize(("rows", "cols"), [(4, 5), (2, 3), (6, 7)])
def test_target_distribution_is_uniform_over_allowed_cells(rows, cols):
    env = WarehouseGridEnv(grid_rows=rows, grid_cols=cols)
    allowed = [(r, c) for r in range(1, rows) for c in range(1, cols)]
    draws_per_cell = 4000
    counts = dict.fromkeys(allowed, 0)
    env.reset(seed=12345)
    for _ in range(draws_per_cell * len(allowed)):
        obs, _ = env.reset()
        cell = (int(obs[2]), int(obs[3]))
        assert cell in counts, f"target {cell} outside rows 1..R-1, columns 1..C-1"
        counts[cell] += 1
    observed = np.array(list(counts.values()), dtype=float)
    chi2 = float(((observed - draws_per_cell) ** 2 / draws_per_cell).sum())
    # A sampler 10 % off on one cell adds 40 to chi2; the bound at p=0.001 is 31 for 11 cells.
    assert chi2 < chi2_critical(len(allowed) - 1), counts
    assert np.abs(observed / draws_per_cell - 1).max() < 0.08, counts


# ---------------------------------------------------------------- determinism
def rollout(env, seed, n_episodes=5, n_steps=30):
    """Targets and observations of a fixed action sequence over several episodes."""
    actions = np.random.default_rng(seed + 1).integers(4, size=n_steps)
    record = []
    obs, _ = env.reset(seed=seed)
    for _ in range(n_episodes):
        record.append(obs.tolist())
        for action in actions:
            obs, reward, terminated, truncated, info = env.step(int(action))
            record.append([*obs.tolist(), reward, terminated, truncated, info["optimal_steps"]])
            if terminated or truncated:
                break
        obs, _ = env.reset()
    return record


def test_same_seed_gives_same_targets_and_trajectory(env_id):
    assert rollout(gym.make(env_id), seed=7) == rollout(gym.make(env_id), seed=7)


def test_different_seeds_give_different_targets(env_cls):
    env = env_cls()
    firsts = {tuple(env.reset(seed=seed)[0][2:]) for seed in range(40)}
    assert len(firsts) > 6
    assert rollout(env_cls(), seed=1) != rollout(env_cls(), seed=2)


def test_trajectories_are_identical_across_processes(run_python):
    """Both environments, in one fresh process (one interpreter to start, not two), in the
    other order there, so that neither case follows the other on both sides."""
    env_ids = list(ENV_CLASSES)
    script = (
        "import gymnasium as gym, warehouse_phys, json\n"
        "from tests.envs.test_envs import rollout\n"
        f"for env_id in {env_ids[::-1]!r}:\n"
        "    print(json.dumps(rollout(gym.make(env_id), seed=99)))\n"
    )
    expected = [json.loads(json.dumps(rollout(gym.make(env_id), seed=99))) for env_id in env_ids]
    assert [json.loads(line) for line in run_python(script).splitlines()] == expected[::-1]


def test_reset_with_target_option_draws_no_random_number(env_cls):
    env = env_cls()
    env.reset(seed=5)
    state = env.np_random.bit_generator.state
    obs, _ = env.reset(options={"target": (2, 3)})
    assert obs.tolist() == [0, 0, 2, 3]
    assert env.np_random.bit_generator.state == state


# ---------------------------------------------------------- gymnasium contract
@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"grid_rows": 2, "grid_cols": 2},
        {"grid_rows": 7},
        {"layout": "maze"},
        {"layout": ["SP"]},
    ],
)
def test_check_env_passes_with_warnings_as_errors(kwargs, env_id):
    env = gym.make(env_id, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("render_mode", [None, "rgb_array", "ansi", "human"])
def test_check_env_passes_in_every_render_mode(render_mode, env_id):
    env = gym.make(env_id, render_mode=render_mode)
    env.unwrapped._renderer.render_fps = 10_000  # the checks, not the 4 fps pacing
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_spaces_and_observation_type(env_id):
    env = gym.make(env_id, grid_rows=3, grid_cols=6)
    assert env.action_space == gym.spaces.Discrete(4)
    assert env.observation_space == gym.spaces.MultiDiscrete([3, 6, 3, 6])
    obs, _ = env.reset(seed=0)
    assert obs.dtype == env.observation_space.dtype == np.int64
    assert obs.shape == (4,)
    assert obs in env.observation_space
    q = np.zeros((3, 6, 3, 6, 4))
    assert q[tuple(obs)].shape == (4,)


def test_observations_are_fresh_arrays(env_cls):
    env = env_cls()
    first, _ = env.reset(seed=0)
    first_copy = first.copy()
    second, _, _, _, _ = env.step(Action.DOWN)
    assert first is not second
    assert not np.shares_memory(first, second)
    second[:] = 0
    assert first.tolist() == first_copy.tolist()
    assert env.step(Action.UP)[0][2:].tolist() == first_copy[2:].tolist()


def test_metadata_declares_render_modes_and_fps(env_cls):
    assert env_cls.metadata["render_modes"] == ["human", "rgb_array", "ansi"]
    assert env_cls.metadata["render_fps"] > 0


def test_registration_and_default_time_limit(env_id):
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == warehouse_phys.DEFAULT_MAX_EPISODE_STEPS == 200
    assert type(env.unwrapped) is ENV_CLASSES[env_id]
    assert (env.unwrapped.grid_rows, env.unwrapped.grid_cols) == (4, 5)
    env.reset(seed=0)
    truncated_at = None
    for step in range(1, 201):
        _, _, terminated, truncated, _ = env.step(Action.UP)  # never reaches a target
        assert not terminated
        if truncated:
            truncated_at = step
            break
    assert truncated_at == 200


def test_time_limit_can_be_changed_by_the_user(env_id):
    env = gym.make(env_id, max_episode_steps=5)
    env.reset(seed=0)
    assert [env.step(Action.LEFT)[3] for _ in range(5)] == [False] * 4 + [True]


def test_module_prefixed_id_works_without_importing_the_package(run_python, env_id):
    script = (
        "import sys, gymnasium as gym\n"
        "assert 'warehouse_phys' not in sys.modules\n"
        f"env = gym.make('warehouse_phys:{env_id}')\n"
        "print(type(env.unwrapped).__name__, env.reset(seed=0)[0].tolist())\n"
    )
    assert run_python(script).startswith(f"{ENV_CLASSES[env_id].__name__} [0, 0, ")


def test_importing_twice_does_not_reregister():
    import importlib

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        importlib.reload(warehouse_phys)
    for env_id in ENV_CLASSES:
        assert gym.make(env_id).spec.id == env_id


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    ("action", "error"),
    [
        (4, ValueError),
        (-1, ValueError),
        (np.int64(17), ValueError),
        (None, TypeError),
        (1.0, TypeError),
        ("1", TypeError),
        (True, TypeError),
        ([1], TypeError),
        (np.array([1, 2]), TypeError),
        (np.array(1.0), TypeError),
    ],
)
def test_invalid_action_names_it_and_the_range_and_changes_nothing(action, error, env_id):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    with pytest.raises(error, match=r"invalid action .*0\.\.3 \(LEFT=0, DOWN=1, RIGHT=2, UP=3\)"):
        env.step(action)
    # The environment is still usable and was not moved.
    after, _, _, truncated, _ = env.step(Action.RIGHT)
    assert after.tolist() == [obs[0], obs[1] + 1, obs[2], obs[3]]
    assert env.unwrapped.grid.move((0, 0), Action.RIGHT) == (0, 1)
    assert not truncated


@pytest.mark.parametrize(
    "action", [2, np.int64(2), np.int8(2), np.uint8(2), np.array(2), Action.RIGHT]
)
def test_integer_actions_of_every_kind_are_accepted(action, env_cls):
    env = env_cls()
    env.reset(options={"target": (2, 2)})
    assert env.step(action)[0][:2].tolist() == [0, 1]


def test_stepping_before_reset_raises(env_id):
    with pytest.raises(ResetNeeded, match="reset"):
        ENV_CLASSES[env_id]().step(0)
    with pytest.raises(ResetNeeded):
        gym.make(env_id).step(0)


@pytest.mark.parametrize(("rows", "cols"), [(1, 5), (4, 1), (0, 3)])
def test_invalid_grid_size_through_make_is_refused(rows, cols, env_id):
    with pytest.raises(ValueError, match="at least 2"):
        gym.make(env_id, grid_rows=rows, grid_cols=cols)


def test_unknown_render_mode_is_refused(env_cls):
    with pytest.raises(ValueError, match="render_mode must be None or one of"):
        env_cls(render_mode="window")


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"target": (0, 3)}, "not a cell the target may occupy"),
        ({"target": (9, 9)}, "off the 4x5 grid"),
        ({"start": (4, 0)}, "off the 4x5 grid"),
        ({"start": (2, 2), "target": (2, 2)}, "is the target's cell"),
        ({"start": (1, 2, 3)}, "must be a \\(row, col\\) pair"),
        ({"start": "a1"}, "must hold two integers"),
        ({"target": (1.0, 2.0)}, "must hold two integers"),
        ({"goal": (1, 1)}, "unknown reset option"),
    ],
)
def test_invalid_reset_options_are_refused(options, message, env_cls):
    env = env_cls()
    with pytest.raises(ValueError, match=message):
        env.reset(options=options)


def test_invalid_reset_options_change_nothing(env_cls):
    env = env_cls()
    env.reset(seed=1)
    env.step(Action.RIGHT)
    rng_state = env.np_random.bit_generator.state
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(seed=5, options={"goal": (1, 1)})
    assert env.np_random.bit_generator.state == rng_state
    assert env.step(Action.RIGHT)[0][:2].tolist() == [0, 2]


def test_start_option_alone_draws_the_target_from_the_other_cells(env_cls):
    env = env_cls(grid_rows=3, grid_cols=3)
    env.reset(seed=0)
    targets = {tuple(env.reset(options={"start": (1, 1)})[0][2:].tolist()) for _ in range(300)}
    assert targets == {(1, 2), (2, 1), (2, 2)}
    obs, info = env.reset(options={"start": (2, 0)})
    assert obs[:2].tolist() == [2, 0]
    assert info["optimal_steps"] == abs(obs[2] - 2) + abs(obs[3] - 0)


def test_stepping_after_termination_follows_the_same_rules(env_cls):
    env = env_cls()
    env.reset(options={"start": (1, 2), "target": (1, 1)})
    assert env.step(Action.LEFT)[1:3] == (1.0, True)
    obs, reward, terminated, _, _ = env.step(Action.DOWN)
    assert (obs[:2].tolist(), reward, terminated) == ([2, 1], 0.0, False)


# -------------------------------------------------------------------- layouts
ROOM = ["S.#", "..#", ".P."]  # a shelf column; the package beyond it, round the bottom


def test_a_layout_sets_the_floor_start_targets_and_distances(env_id):
    env = gym.make(env_id, layout=ROOM)
    assert env.observation_space == gym.spaces.MultiDiscrete([3, 3, 3, 3])
    assert env.unwrapped.grid.shelves == {(0, 2), (1, 2)}
    obs, info = env.reset(seed=0)
    assert obs.tolist() == [0, 0, 2, 1]  # the only package cell
    assert info["optimal_steps"] == 3
    obs, _, _, _, info = env.step(Action.RIGHT)
    assert (obs[:2].tolist(), info["optimal_steps"]) == ([0, 1], 2)


def test_moving_into_a_shelf_stays_put_and_counts(env_id):
    env = gym.make(env_id, layout=ROOM, max_episode_steps=3)
    env.reset(options={"start": (1, 1), "target": (2, 1)})
    for _ in range(2):
        obs, reward, terminated, truncated, info = env.step(Action.RIGHT)  # (1, 2) is a shelf
        assert (obs[:2].tolist(), reward, terminated, truncated) == ([1, 1], 0.0, False, False)
        assert info["optimal_steps"] == 1
    assert env.step(Action.RIGHT)[3] is True


def test_the_ansi_picture_shows_shelves():
    env = gym.make(ENV_ID, layout=ROOM, render_mode="ansi")
    env.reset(seed=0)
    assert env.render() == "R _ # \n_ _ # \n_ T _ \n"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"layout": "office"}, "unknown layout preset 'office'"),
        ({"layout": ["S..", ".."]}, "row 1 has 2 cells, row 0 has 3"),
        ({"layout": ["S.x"]}, "unknown layout symbol 'x' at row 0, column 2"),
        ({"layout": "maze", "grid_rows": 4}, "grid_rows=4 contradicts the layout, which has 5"),
        ({"layout": ["S#", "#P"]}, r"package cells \[\(1, 1\)\] cannot be reached"),
    ],
)
def test_invalid_layouts_are_refused_through_make(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"start": (0, 2)}, r"options\['start'\] \(0, 2\) is a shelf"),
        ({"target": (0, 1)}, r"not a cell the target may occupy \(see grid.target_cells\)"),
        ({"start": (2, 1)}, r"options\['start'\] \(2, 1\) is the only cell the target may"),
    ],
)
def test_reset_options_respect_the_layout(env_id, options, message):
    env = gym.make(env_id, layout=ROOM)
    with pytest.raises(ValueError, match=message):
        env.reset(options=options)


def test_a_start_option_in_a_walled_off_room_is_refused(env_id):
    env = gym.make(env_id, layout=["S.#.", "..#.", "###."])
    with pytest.raises(ValueError, match=r"\(0, 3\) cannot be reached from the layout's start"):
        env.reset(options={"start": (0, 3)})


# ------------------------------------------------------------- copy and pickle
def path_or_none(env):
    base = env.unwrapped
    return base.last_move_path.tobytes() if getattr(base, "record_path", False) else None


def play_in_lockstep(original, duplicate, seed, n_actions=250):
    """Step both with the same random actions (resetting on episode ends); assert equality."""
    actions = np.random.default_rng(seed).integers(4, size=n_actions).tolist()
    for action in actions:
        a, b = original.step(action), duplicate.step(action)
        assert np.array_equal(a[0], b[0])
        assert a[1:4] == b[1:4]
        assert a[4] == b[4]
        assert path_or_none(original) == path_or_none(duplicate)
        if a[2] or a[3]:
            assert np.array_equal(original.reset()[0], duplicate.reset()[0])


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("stage", ["before reset", "after reset", "mid-episode"])
@pytest.mark.parametrize("made", ["gym.make", "unwrapped"])
@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        (warehouse_phys.GRID_ENV_ID, {}),
        (warehouse_phys.PHYSICS_ENV_ID, {"record_path": True}),
        ("warehouse-robot-phys-maze-v0", {"render_mode": "rgb_array"}),
    ],
    ids=["grid", "phys", "phys-maze-rgb"],
)
def test_a_copy_continues_bit_for_bit_with_the_original(env_id, kwargs, made, stage, how):
    import copy
    import pickle

    env = gym.make(env_id, max_episode_steps=40, **kwargs)
    env = env if made == "gym.make" else env.unwrapped
    if stage != "before reset":
        env.reset(seed=7)
    if stage == "mid-episode":
        for action in [2, 1, 0, 0, 3, 1, 2]:  # includes moves into a wall
            env.step(action)
        if env.render_mode == "rgb_array":
            env.render()  # the renderer now holds pygame surfaces
    duplicate = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    if stage == "before reset":
        env.reset(seed=3)
        duplicate.reset(seed=3)
    play_in_lockstep(env, duplicate, seed=11)
    if env.render_mode == "rgb_array":
        assert np.array_equal(env.render(), duplicate.render())


# ------------------------------------------------------------------ small inputs
@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        (5, TypeError, r"reset options must be a dict or None, got 5 \(int\)"),
        ({"target"}, TypeError, r"reset options must be a dict or None, got \{'target'\} \(set\)"),
        ([("target", (1, 1))], TypeError, "reset options must be a dict or None"),
        ({1: 2, "x": 3}, ValueError,
         r"unknown reset option\(s\) 1, 'x'; known: \['start', 'target'\]"),
    ],
)  # fmt: skip
def test_malformed_reset_options_are_refused_by_name(env_id, options, error, message):
    env = gym.make(env_id)
    env.reset(seed=0)
    before = env.unwrapped.np_random.bit_generator.state
    with pytest.raises(error, match=message):
        env.reset(seed=1, options=options)
    assert env.unwrapped.np_random.bit_generator.state == before  # nothing changed


@pytest.mark.parametrize(
    "action", [np.timedelta64(2), np.array(np.timedelta64(2, "s")), np.datetime64(2, "D")]
)
def test_time_values_are_not_actions(env_id, action):
    env = gym.make(env_id)
    env.reset(seed=0)
    with pytest.raises(TypeError, match=r"expected an integer in 0\.\.3"):
        env.step(action)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"grid_rows": "7"}, TypeError, r"grid_rows must be an integer, got '7' \(str\)"),
        ({"grid_cols": 7.0}, TypeError, r"grid_cols must be an integer, got 7.0 \(float\)"),
        ({"grid_rows": True}, TypeError, "grid_rows must be an integer"),
    ],
)
def test_sizes_given_with_a_layout_are_checked_by_name(env_id, kwargs, error, message):
    with pytest.raises(error, match=message):
        gym.make(env_id, layout="maze", **kwargs)


# -------------------------------------------------------------------- big floors
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"grid_rows": 2049},
         "grid_rows must be at most 2048, got 2049: the largest floor is 2048 x 2048"),
        ({"grid_cols": 100_000}, "grid_cols must be at most 2048"),
        ({"grid_rows": 2**63}, "grid_rows must be at most 2048"),
        ({"layout": ["S" + "." * 2048]}, "the layout has 1 rows of 2049 cells: the largest"),
    ],
)  # fmt: skip
def test_floors_beyond_the_largest_are_refused_at_once(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


def big_layout(n):
    """An n x n floor of aisles: shelf runs in every other row, gaps at both ends."""
    shelf_row = "." + "#" * (n - 2) + "."
    return ["S" + "." * (n - 1)] + [shelf_row if r % 2 else "." * n for r in range(1, n)]


@pytest.mark.slow
@pytest.mark.parametrize("floor", ["plain", "layout"])
def test_a_256_by_256_floor_builds_and_steps_in_both_worlds(env_id, floor):
    kwargs = (
        {"grid_rows": 256, "grid_cols": 256} if floor == "plain" else {"layout": big_layout(256)}
    )
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    grid = env.unwrapped.grid
    for action in np.random.default_rng(0).integers(4, size=50).tolist():
        robot = (int(obs[0]), int(obs[1]))
        obs, _, terminated, _, info = env.step(action)
        assert (obs[0], obs[1]) == grid.move(robot, action)
        assert info["optimal_steps"] == grid.optimal_steps((obs[0], obs[1]), (obs[2], obs[3]))
        if terminated:
            obs, info = env.reset()


@pytest.mark.parametrize("render_mode", ["rgb_array", "human"])
def test_frames_too_large_to_draw_are_refused_when_built(env_id, render_mode):
    with pytest.raises(
        ValueError, match=r"a 200x200 floor at cell_px=64 makes frames of 12800x12824 pixels"
    ):
        gym.make(env_id, grid_rows=200, grid_cols=200, render_mode=render_mode)
    small = gym.make(env_id, grid_rows=200, grid_cols=200, render_mode="rgb_array", cell_px=16)
    small.reset(seed=0)
    assert small.render().shape == (200 * 16 + 20, 200 * 16, 3)


def test_distance_maps_are_bounded_on_big_floors():
    env = gym.make(ENV_ID, layout=big_layout(200))
    grid = env.unwrapped.grid
    for target in grid.target_cells[:60]:  # more targets than the 52 maps kept
        env.reset(options={"target": target})
    assert len(grid._distances) <= grid._distance_cache_size
    assert grid._distance_cache_size == 2**21 // (200 * 200)


# ------------------------------------------------------------ what a person sees
def test_the_frame_shows_a_delivered_package(env_id):
    env = gym.make(env_id, render_mode="rgb_array", grid_rows=3, grid_cols=3)
    env.reset(options={"target": (1, 1)})
    env.step(Action.DOWN)
    before = env.render()
    assert "Delivered" not in env.unwrapped._status_text()
    _, reward, terminated, _, _ = env.step(Action.RIGHT)
    assert (reward, terminated) == (1.0, True)
    after = env.render()
    assert "Delivered!" in env.unwrapped._status_text()
    cell = after[64:128, 64:128].astype(int)
    # The cell is framed in green and the carried package shows in its top-right quarter.
    frame_colour = np.array(warehouse_phys.drawing.render.DELIVERED_FRAME)
    assert (np.abs(cell[0] - frame_colour).sum(axis=1) == 0).all()
    robot_only = gym.make(env_id, render_mode="rgb_array", grid_rows=3, grid_cols=3)
    robot_only.reset(options={"target": (2, 2), "start": (1, 1)})
    robot_only.unwrapped._last_action = Action.RIGHT
    plain = robot_only.render()[64:128, 64:128].astype(int)
    assert np.abs(cell[4:28, 36:60] - plain[4:28, 36:60]).mean() > 20
    assert not np.array_equal(before[192:], after[192:])  # the status line changed


def test_the_window_is_titled_with_the_environment_id(env_id):
    import pygame

    env = gym.make(env_id, render_mode="human")
    try:
        env.reset(seed=0)
        assert pygame.display.get_caption()[0] == f"warehouse_phys: {env_id}"
    finally:
        env.close()


# ------------------------------------------------- refused calls change nothing
SINGLE_BAD_CALLS = [
    ("reset", {"seed": -1}),
    ("reset", {"seed": 1.5}),
    ("reset", {"seed": "0"}),
    ("reset", {"seed": 5, "options": {"goal": (1, 1)}}),
    ("reset", {"seed": 5, "options": {"target": {1: 1, 2: 2}}}),
    ("reset", {"options": {"target": {1, 2}}}),
    ("reset", {"options": {"target": (np.timedelta64(1), 1)}}),
    ("reset", {"options": {"target": (0, 3)}}),
    ("reset", {"options": 5}),
    ("step", 4),
    ("step", -1),
    ("step", 1.5),
    ("step", None),
    ("step", True),
    ("step", "1"),
    ("step", np.timedelta64(1)),
    ("step", np.ma.masked),
    ("step", np.ma.masked_array(1, mask=True)),
    ("step", np.array([1, 2])),
    ("step", 2**63),
    ("step", np.uint64(2**63)),
    ("step", -(2**64)),
    ("step", 10**5000),
    ("reset", {"options": {"target": (10**5000, 1)}}),
]
VECTOR_BAD_CALLS = [
    ("reset", {"seed": -1}),
    ("reset", {"seed": 2.5}),
    ("reset", {"seed": 5, "options": {"goal": 1}}),
    ("reset", {"options": {"reset_mask": [True, False, True]}}),
    ("reset", {"seed": 5, "options": {"reset_mask": np.zeros(3, dtype=bool)}}),
    ("step", np.array([0, 4, 1])),
    ("step", np.array([0, -1, 1], dtype=">i8")),
    ("step", [1, [2, 3], 2]),
    ("step", [1, np.ma.masked, 2]),
    ("step", np.ma.masked_array([1, 2, 3], mask=[0, 0, 1])),
    ("step", np.array([1, 2, 3], dtype="m8")),
    ("step", np.ones(3)),
    ("step", np.ones(4, dtype=np.int64)),
    ("step", [2**63, 0, 0]),
    ("step", [np.uint64(2**63), 0, 0]),
    ("step", [10**5000, 0, 0]),
    ("step", [np.ma.masked_array(1, mask=True), 0, 0]),
    ("step", np.ma.masked),
    ("step", np.ma.masked_array(1, mask=True)),
    ("step", [True, 0, 0]),
    ("step", [np.int8(2), np.uint64(1), 4]),
    ("step", [np.int8(2), np.uint64(1), 1.0]),
    ("reset", {"options": {"reset_mask": np.ma.masked_array([True] * 3, mask=[1, 0, 0])}}),
]
ALL_ENVS = {
    "grid": (lambda: gym.make(ENV_ID).unwrapped, SINGLE_BAD_CALLS),
    "phys": (lambda: gym.make(warehouse_phys.PHYSICS_ENV_ID).unwrapped, SINGLE_BAD_CALLS),
    "vector grid": (lambda: gym.make_vec(ENV_ID, num_envs=3), VECTOR_BAD_CALLS),
    "vector phys": (
        lambda: gym.make_vec(warehouse_phys.PHYSICS_ENV_ID, num_envs=3),
        VECTOR_BAD_CALLS,
    ),
}


def _state(env) -> tuple:
    """Everything a refused call must leave alone: the whole object, its observation and
    its generator."""
    obs = env._observations() if hasattr(env, "num_envs") else env._get_obs()
    return pickle.dumps(env), obs.tolist(), env.np_random.bit_generator.state


@pytest.mark.parametrize("name", list(ALL_ENVS))
@given(data=st.data())
@settings(max_examples=12, deadline=None)
def test_a_refused_call_changes_nothing(name, data):
    make, bad_calls = ALL_ENVS[name]
    env = make()
    vector = hasattr(env, "num_envs")
    env.reset(seed=data.draw(st.integers(0, 2**32 - 1), label="seed"))
    actions = st.lists(st.integers(0, 3), min_size=3, max_size=3) if vector else st.integers(0, 3)
    for action in data.draw(st.lists(actions, max_size=25), label="history"):
        env.step(np.array(action) if vector else action)
    twin = copy.deepcopy(env)
    before = _state(env)
    for method, argument in bad_calls:
        call = getattr(env, method)
        with pytest.raises((TypeError, ValueError, gym.error.Error)):
            call(**argument) if method == "reset" else call(argument)
        assert _state(env) == before, (method, argument)
    for action in data.draw(st.lists(actions, min_size=1, max_size=5), label="after"):
        action = np.array(action) if vector else action
        for got, expected in zip(env.step(action), twin.step(action), strict=True):
            if isinstance(got, dict):
                assert got.keys() == expected.keys()
                got, expected = list(got.values()), list(expected.values())
            np.testing.assert_equal(got, expected)


# ------------------------------------------------------------------ no display
HEADLESS_CHECK = """
import warnings
import gymnasium as gym
from gymnasium.utils.env_checker import check_env
import warehouse_phys
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    check_env(gym.make("warehouse-robot-phys-v0").unwrapped)  # makes every render mode
    check_env(gym.make("warehouse-robot-v0").unwrapped)
    env = gym.make("warehouse-robot-v0", render_mode="human")
    env.reset(seed=0)
    env.step(1)
    env.close()
import os, pygame
print(os.environ["SDL_VIDEODRIVER"], pygame.display.get_init())
for warning in caught:
    print(warning.category.__name__, warning.message)
"""


@pytest.mark.slow
def test_human_mode_without_a_display_warns_once_and_draws_offscreen(run_python):
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")}  # fmt: skip
    lines = run_python(HEADLESS_CHECK, env=env).splitlines()
    assert lines[0] == "dummy False"
    assert len(lines) == 2
    assert lines[1].startswith("UserWarning render_mode='human' found no display")


def test_human_mode_leaves_a_chosen_driver_alone(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym.make(ENV_ID, render_mode="human").close()


# ------------------------------------------------------- odd values, named refusals
@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"grid_rows": np.timedelta64(4)}, TypeError,
         r"^grid_rows must be an integer, got np.timedelta64\(4\) \(timedelta64\)"),
        ({"grid_cols": np.timedelta64(5), "layout": "maze"}, TypeError,
         "^grid_cols must be an integer"),
        ({"cell_px": np.timedelta64(64)}, TypeError, "^cell_px must be an integer"),
        ({"render_mode": 1}, TypeError,
         r"^render_mode must be None or one of \['human', 'rgb_array', 'ansi'\], got 1 \(int\)"),
        ({"render_mode": ["human"]}, TypeError, "^render_mode must be None or one of"),
    ],
)  # fmt: skip
def test_odd_arguments_are_refused_in_one_line_by_name(env_id, kwargs, error, message):
    with pytest.raises(error, match=message) as caught:
        gym.make(env_id, **kwargs)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"target": {1: 1, 2: 2}}, r"options\['target'\] must be a \(row, col\) pair, .*\(dict"),
        ({"target": {1, 2}}, r"options\['target'\] must be a \(row, col\) pair, .*\(set"),
        ({"start": {"row": 1, "col": 1}}, r"options\['start'\] must be a \(row, col\) pair"),
    ],
)
def test_unordered_cells_are_refused(env_cls, options, message):
    env = env_cls()
    with pytest.raises(TypeError, match=message):
        env.reset(seed=0, options=options)
    with pytest.raises(ValueError, match=r"options\['target'\] must hold two integers"):
        env.reset(seed=0, options={"target": (np.timedelta64(1), 1)})


@pytest.mark.parametrize(
    "action", [np.ma.masked, np.ma.masked_array(2, mask=True)], ids=["masked", "masked array"]
)
def test_a_masked_action_is_refused_in_one_line(env_id, action):
    env = gym.make(env_id)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^invalid action: a masked value \(Masked") as caught:
        env.step(action)
    assert "\n" not in str(caught.value)
    assert env.step(np.ma.masked_array(2, mask=False))[0][:2].tolist() == [0, 1]  # unmasked


def test_a_big_endian_action_is_an_action(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    assert env.step(np.array(2, dtype=">i8"))[0][:2].tolist() == [0, 1]
    assert env.step(np.array(1, dtype=">u2"))[0][:2].tolist() == [1, 1]


# ------------------------------------------------------- deep-RL options (issue 23)
def test_step_and_bump_penalties_shape_the_reward(env_id):
    env = gym.make(env_id, step_penalty=0.01, bump_penalty=0.1)
    env.reset(seed=0, options={"target": (1, 1)})
    actions = (Action.LEFT, Action.UP, Action.RIGHT, Action.RIGHT, Action.DOWN)
    rewards = [env.step(action)[1] for action in actions]
    assert rewards == pytest.approx([-0.11, -0.11, -0.01, -0.01, -0.01])  # 2 bumps, 3 moves
    assert env.step(Action.LEFT)[1:3] == (1.0, True)  # reaching the package costs nothing


def test_penalties_default_to_zero_and_leave_the_rewards_alone(env_id):
    env = gym.make(env_id)
    assert (env.unwrapped.step_penalty, env.unwrapped.bump_penalty) == (0.0, 0.0)
    env.reset(seed=0, options={"target": (1, 1)})
    assert [env.step(a)[1] for a in (Action.LEFT, Action.DOWN, Action.RIGHT)] == [0.0, 0.0, 1.0]


@pytest.mark.parametrize(
    ("value", "error"),
    [(-0.1, ValueError), (math.nan, ValueError), (math.inf, ValueError), ("0.1", TypeError),
     (None, TypeError), (True, TypeError), (np.timedelta64(1), TypeError)],
)  # fmt: skip
@pytest.mark.parametrize("keyword", ["step_penalty", "bump_penalty"])
def test_bad_penalties_are_refused_by_name(env_id, keyword, value, error):
    with pytest.raises(error, match=keyword):
        gym.make(env_id, **{keyword: value})


def test_onehot_observation_encodes_the_four_cells(env_id):
    cells = gym.make(env_id)
    onehot = gym.make(env_id, observation="onehot")
    assert onehot.observation_space == gym.spaces.Box(0, 1, (18,), np.float32)
    expected, _ = cells.reset(seed=3)
    obs, _ = onehot.reset(seed=3)
    for action in [Action.DOWN, Action.RIGHT, Action.RIGHT, Action.LEFT, Action.DOWN]:
        assert obs.dtype == np.float32
        assert obs in onehot.observation_space
        offsets = np.array([0, 4, 9, 13])  # 0, R, R + C, 2R + C on the 4 x 5 floor
        assert np.flatnonzero(obs).tolist() == (expected + offsets).tolist()
        expected = cells.step(action)[0]
        obs = onehot.step(action)[0]


def test_onehot_observation_passes_check_env(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, observation="onehot", step_penalty=0.01).unwrapped)


@pytest.mark.parametrize(("value", "error"), [("one-hot", ValueError), (1, TypeError)])
def test_an_unknown_observation_is_refused_by_name(env_id, value, error):
    with pytest.raises(error, match="observation must be one of"):
        gym.make(env_id, observation=value)


# ------------------------------------------------ numbers too big for a float (issue 32)
@pytest.mark.parametrize(
    "value", [10**400, -(10**400), 10**5000], ids=["1e400", "-1e400", "1e5000"]
)
@pytest.mark.parametrize("keyword", ["step_penalty", "bump_penalty"])
def test_a_penalty_too_big_for_a_float_is_refused_by_name(env_id, keyword, value):
    message = f"^{keyword} must be a finite number >= 0, got a"
    with pytest.raises(ValueError, match=message) as caught:
        gym.make(env_id, **{keyword: value})
    assert "\n" not in str(caught.value)
    assert "bits" in str(caught.value)  # its size, not its 5000 digits


def test_penalties_whose_sum_overflows_are_refused(env_id):
    with pytest.raises(ValueError, match=r"^step_penalty \+ bump_penalty must be finite"):
        gym.make(env_id, step_penalty=1e308, bump_penalty=1e308)


@pytest.mark.parametrize(
    ("value", "expected"),
    [(np.float32(0.5), 0.5), (np.int64(2), 2.0), (np.uint8(0), 0.0), (2**63, 2.0**63)],
)
def test_numpy_and_large_integer_penalties_are_plain_floats(env_id, value, expected):
    env = gym.make(env_id, step_penalty=value, bump_penalty=value).unwrapped
    assert (type(env.step_penalty), type(env.bump_penalty)) == (float, float)
    assert env.step_penalty == env.bump_penalty == expected
    with pytest.raises(TypeError, match=r"^bump_penalty must be a real number"):
        gym.make(env_id, bump_penalty=np.bool_(False))


@pytest.mark.parametrize(
    ("action", "error", "message"),
    [
        (2**63, ValueError, r"^invalid action 9223372036854775808: expected an integer in 0..3"),
        (np.uint64(2**63), ValueError, r"^invalid action np.uint64\(9223372036854775808\)"),
        (10**5000, ValueError, r"^invalid action \(an integer of 16610 bits\): expected"),
        (-(10**5000), ValueError, r"^invalid action \(a negative integer of 16610 bits\)"),
        (np.ma.masked, ValueError, r"^invalid action: a masked value \(MaskedConstant\)"),
        (np.ma.masked_array(1, mask=True), ValueError, r"^invalid action: a masked value"),
    ],
    ids=["2**63", "uint64", "1e5000", "-1e5000", "masked", "masked array"],
)  # fmt: skip
def test_actions_beyond_int64_or_masked_are_refused_in_one_line(env_id, action, error, message):
    env = gym.make(env_id)
    env.reset(seed=0)
    with pytest.raises(error, match=message) as caught:
        env.step(action)
    assert "\n" not in str(caught.value)
    assert env.step(Action.RIGHT)[0][:2].tolist() == [0, 1]  # as if it never happened


def test_a_target_beyond_int64_is_refused_in_one_line(env_id):
    env = gym.make(env_id)
    with pytest.raises(ValueError, match=r"^options\['target'\] \(an integer of 16610 bits, 1\)"):
        env.reset(seed=0, options={"target": (10**5000, 1)})
