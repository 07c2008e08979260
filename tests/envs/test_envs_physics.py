"""The physics-backed environment: equal to the grid twin, deterministic, bounded, drawable.

The Gymnasium contract (spaces, checker, bad actions, reset options) is tested
for both environments in ``test_envs.py``.
"""

import dataclasses
import gc
import hashlib
from pathlib import Path

import gymnasium as gym
import numpy as np
import pymunk
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_match import check_environments_match
from hypothesis import given, settings
from hypothesis import strategies as st

import warehouse_phys
from tests.drawing.test_render import robot_centre
from tests.world.test_grid import layouts
from warehouse_phys import SNAP_ERROR_BOUND, Action, WarehousePhysicsEnv
from warehouse_phys.envs import single as envs_module
from warehouse_phys.physics import PhysicsConfig

GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID


def step_record(result):
    obs, reward, terminated, truncated, info = result
    return obs.tolist(), reward, terminated, truncated, info["optimal_steps"]


def run_both_envs(grid, phys, actions, seed=0):
    """Play ``actions`` in both environments, resetting each when its episode ends.

    Returns the two records (reset states and steps) and the largest snap error seen.
    """
    records = ([], [])
    worst = 0.0
    for env, record in zip((grid, phys), records, strict=True):
        obs, info = env.reset(seed=seed)
        record.append((obs.tolist(), info["optimal_steps"]))
    for action in actions:
        for env, record in zip((grid, phys), records, strict=True):
            result = env.step(action)
            record.append(step_record(result))
            if env is phys:
                worst = max(worst, result[4]["snap_error"])
            if result[2] or result[3]:
                obs, info = env.reset()
                record.append((obs.tolist(), info["optimal_steps"]))
    return records[0], records[1], worst


def run_both(actions, seed, max_episode_steps=200, **kwargs):
    """:func:`run_both_envs` on a grid twin and a physics twin made with ``kwargs``."""
    grid = gym.make(GRID_ID, max_episode_steps=max_episode_steps, **kwargs)
    phys = gym.make(PHYS_ID, max_episode_steps=max_episode_steps, **kwargs)
    return run_both_envs(grid, phys, actions, seed)


# ---------------------------------------------------------------- equivalence
@settings(max_examples=60)
@given(
    rows=st.integers(2, 8),
    cols=st.integers(2, 8),
    seed=st.integers(0, 2**32 - 1),
    actions=st.lists(st.sampled_from(list(Action)), min_size=1, max_size=120),
    max_episode_steps=st.sampled_from([3, 20, 200]),
)
def test_both_worlds_give_identical_trajectories(rows, cols, seed, actions, max_episode_steps):
    grid, phys, worst = run_both(actions, seed, max_episode_steps, grid_rows=rows, grid_cols=cols)
    assert phys == grid
    assert worst < SNAP_ERROR_BOUND


@settings(max_examples=40)
@given(
    layout=layouts(),
    seed=st.integers(0, 2**32 - 1),
    actions=st.lists(st.sampled_from(list(Action)), min_size=1, max_size=120),
)
def test_both_worlds_agree_around_shelves(layout, seed, actions):
    grid, phys, worst = run_both(actions, seed, 40, layout=layout)
    assert phys == grid
    assert worst < SNAP_ERROR_BOUND


@pytest.mark.parametrize(
    ("kwargs", "render_mode", "num_steps"),
    [
        ({}, "rgb_array", 400),  # renders are compared too: the post-move frames are equal
        ({"grid_rows": 2, "grid_cols": 2}, None, 2000),
        ({"grid_rows": 8, "grid_cols": 8}, None, 2000),
        ({"grid_rows": 3, "grid_cols": 7}, "ansi", 2000),
        ({"layout": "aisles"}, "rgb_array", 300),
        ({"layout": "depot"}, None, 3000),
        ({"layout": "maze"}, "ansi", 3000),
    ],
)
def test_gymnasium_finds_the_environments_match(kwargs, render_mode, num_steps):
    grid = gym.make(GRID_ID, render_mode=render_mode, **kwargs)
    phys = gym.make(PHYS_ID, render_mode=render_mode, **kwargs)
    # env_b's info must hold env_a's: the physics adds "snap_error".
    check_environments_match(grid, phys, num_steps=num_steps, seed=11, info_comparison="superset")


def make_unchecked(monkeypatch, **physics):
    """The physics-backed environment with settings its constructor would refuse."""
    monkeypatch.setattr(envs_module, "check_controller", lambda config: None)
    return gym.make(PHYS_ID, **physics)


def test_a_controller_too_weak_to_arrive_is_caught_by_the_equivalence_check(monkeypatch):
    grid = gym.make(GRID_ID)
    phys = make_unchecked(monkeypatch, max_force=40.0)  # 2 m/s^2: a few cm in a move
    with pytest.raises(AssertionError, match="stepping observation is not equivalent"):
        check_environments_match(grid, phys, num_steps=50, seed=0, info_comparison="superset")


def test_a_controller_that_overshoots_is_caught_by_the_snap_bound(monkeypatch):
    # Fast, with too little force to brake: it sails about 0.4 of a cell past each
    # centre. The cells still match the grid twin; the snap bound catches it.
    overshooting = {"max_speed": 17.0, "max_force": 1500.0, "floor_damping": 0.01}
    grid, phys = gym.make(GRID_ID), make_unchecked(monkeypatch, **overshooting)
    actions = np.random.default_rng(0).integers(4, size=300).tolist()
    grid_record, phys_record, worst = run_both_envs(grid, phys, actions)
    assert phys_record == grid_record
    assert worst > 0.3
    monkeypatch.undo()
    with pytest.raises(ValueError, match=r"not within half the bound of 0\.02"):
        gym.make(PHYS_ID, **overshooting)


def test_a_controller_too_weak_to_arrive_is_refused_when_built():
    with pytest.raises(ValueError, match=r"a free move from \(2, 2\) \(LEFT\) ends on \(2, 2\)"):
        gym.make(PHYS_ID, max_force=40.0)


# ------------------------------------------------------------------ long run
def resident_memory_bytes() -> int:
    return int(Path("/proc/self/statm").read_text().split()[1]) * 4096


LONG_RUNS = {
    # 30,000 actions over hundreds of episodes on an empty 5 x 6 floor...
    "empty": (30_000, {"grid_rows": 5, "grid_cols": 6}, 480),
    # ... and 15,000 around the shelves of each preset.
    **{name: (15_000, {"layout": name}, 190) for name in warehouse_phys.PRESETS},
}


@pytest.mark.slow
@pytest.mark.parametrize("floor", list(LONG_RUNS))
def test_long_run_stays_on_the_floor_bounded_and_equal_to_the_grid_twin(floor):
    """Random actions over many episodes, checked after every physics step."""
    n_actions, kwargs, min_episodes = LONG_RUNS[floor]
    rng = np.random.default_rng(2024)
    actions = rng.integers(4, size=n_actions).tolist()
    grid = gym.make(GRID_ID, max_episode_steps=60, **kwargs)
    phys = gym.make(PHYS_ID, max_episode_steps=60, record_path=True, **kwargs)
    unwrapped = phys.unwrapped
    radius = unwrapped.physics.robot_radius / unwrapped.physics.cell_size
    # The body's centre stays inside the walls, less its radius and one step of overlap.
    overlap = unwrapped.physics.max_speed * unwrapped.physics.dt / unwrapped.physics.cell_size
    low = -0.5 + radius - overlap
    high = np.array([unwrapped.grid_rows, unwrapped.grid_cols]) - 0.5 - radius + overlap
    # The shelves' cells, with a ring of cells round the floor (a body a little past a wall).
    in_shelf = np.pad(unwrapped.grid.shelf_mask, 1)
    grid.reset(seed=5)
    phys.reset(seed=5)
    episodes, worst, memory_after_warmup = 0, 0.0, None
    lowest, highest = np.full(2, np.inf), np.full(2, -np.inf)
    paths = []  # every physics step of the episode so far, checked at its end (fewer calls)
    for i, action in enumerate(actions):
        g_obs, g_rew, g_term, g_trunc, g_info = grid.step(action)
        p_obs, p_rew, p_term, p_trunc, p_info = phys.step(action)
        assert np.array_equal(p_obs, g_obs), (i, p_obs, g_obs)
        assert (p_rew, p_term, p_trunc) == (g_rew, g_term, g_trunc)
        assert p_info["optimal_steps"] == g_info["optimal_steps"]
        worst = max(worst, p_info["snap_error"])
        paths.append(unwrapped.last_move_path)
        if g_term or g_trunc or i == len(actions) - 1:
            path = np.concatenate(paths)
            paths.clear()
            lowest = np.minimum(lowest, path.min(axis=0))
            highest = np.maximum(highest, path.max(axis=0))
            # The body's centre never gets inside a shelf's cell.
            cells = np.floor(path + 0.5).astype(np.int64) + 1
            inside = in_shelf[cells[:, 0], cells[:, 1]]
            assert not inside.any(), (i, path[inside])
        if g_term or g_trunc:
            episodes += 1
            assert np.array_equal(grid.reset()[0], phys.reset()[0])
            if episodes == min_episodes // 10:
                gc.collect()
                memory_after_warmup = resident_memory_bytes()
    assert episodes > min_episodes
    assert worst < SNAP_ERROR_BOUND, worst
    assert np.isfinite(lowest).all()
    assert np.isfinite(highest).all()
    assert (lowest >= low).all(), lowest
    assert (highest <= high).all(), highest
    # Thousands of resets later, memory has not grown with them (a leaked space
    # per reset would add several megabytes), and only the live world's space is left.
    gc.collect()
    assert resident_memory_bytes() - memory_after_warmup < 4 * 2**20
    # type(), not isinstance(): a dead weak proxy among the objects (numba leaves some when
    # a compiled function is freed) raises ReferenceError when asked for its class.
    assert sum(type(obj) is pymunk.Space for obj in gc.get_objects()) <= 2


# --------------------------------------------------------------- determinism
def body_trajectory(seed=3, n_actions=400, env_id=PHYS_ID):
    """Every recorded body position of a fixed-seed run with resets, as raw float64 bytes."""
    env = gym.make(env_id, record_path=True, max_episode_steps=50)
    actions = np.random.default_rng(seed).integers(4, size=n_actions).tolist()
    env.reset(seed=seed)
    chunks = []
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        chunks.append(env.unwrapped.last_move_path)
        if terminated or truncated:
            env.reset()
    return np.concatenate(chunks)


def digest(path: np.ndarray) -> str:
    return hashlib.sha256(path.tobytes()).hexdigest()


def test_body_trajectories_are_bit_identical_across_processes(run_python):
    """Both floors, in one fresh process (one interpreter to start, not two), in the other
    order there, so that neither case follows the other on both sides."""
    env_ids = [PHYS_ID, "warehouse-robot-phys-aisles-v0"]
    script = (
        "from tests.envs.test_envs_physics import body_trajectory, digest\n"
        f"for env_id in {env_ids[::-1]!r}:\n"
        "    path = body_trajectory(env_id=env_id)\n"
        "    print(path.shape[0], digest(path))\n"
    )
    expected = []
    for env_id in env_ids:
        here = body_trajectory(env_id=env_id)
        assert here.shape[0] == 400 * 15
        expected = [str(here.shape[0]), digest(here), *expected]  # the other order
    assert run_python(script).split() == expected


def test_reset_rebuilds_the_robot_so_an_episode_replays_bit_for_bit():
    bumps = [Action.UP, Action.LEFT, Action.UP, Action.RIGHT, Action.DOWN, Action.LEFT]
    replay = [Action.LEFT, Action.RIGHT, Action.RIGHT, Action.UP, Action.DOWN, Action.DOWN]

    def run(env, actions):
        out = []
        for action in actions:
            env.step(action)
            out.append(env.last_move_path)
        return np.concatenate(out)

    used = WarehousePhysicsEnv(record_path=True)
    used.reset(seed=1)
    run(used, bumps)  # leaves contacts and warm-started impulses behind
    used.reset(seed=2)
    assert used.world.space.current_time_step == 0.0
    assert used.world.joint.impulse == 0.0  # renewed: no accumulated impulse
    assert set(used.world.space.bodies) == {used.world.robot, used.world.control}
    robot = used.world.robot
    assert (robot.velocity, robot.angle, robot.angular_velocity) == ((0, 0), 0.0, 0.0)
    assert robot.position == used.world.control.position == (0.5, 0.5)
    fresh = WarehousePhysicsEnv(record_path=True)
    fresh.reset(seed=2)
    assert run(used, replay).tobytes() == run(fresh, replay).tobytes()


def test_same_seed_same_target_as_the_grid_twin():
    for seed in range(30):
        grid_obs, _ = gym.make(GRID_ID).reset(seed=seed)
        phys_obs, _ = gym.make(PHYS_ID).reset(seed=seed)
        assert np.array_equal(grid_obs, phys_obs)


# ---------------------------------------------------------------- env surface
def test_info_reports_the_snap_error():
    env = gym.make(PHYS_ID)
    _, info = env.reset(seed=0)
    assert info == {"optimal_steps": info["optimal_steps"], "snap_error": 0.0}
    errors = [env.step(action)[4]["snap_error"] for action in [1, 2, 3, 0, 0, 3]]
    assert all(isinstance(e, float) and 0.0 <= e < SNAP_ERROR_BOUND for e in errors)
    assert max(errors) > 0.0  # measured, not a constant


def test_physical_parameters_are_keyword_arguments_with_documented_defaults():
    env = gym.make(PHYS_ID, robot_radius=0.25, max_force=3500.0, move_duration=0.3)
    physics = env.unwrapped.physics
    assert physics == dataclasses.replace(
        PhysicsConfig(), robot_radius=0.25, max_force=3500.0, move_duration=0.3
    )
    assert physics.steps_per_move == 18
    env.reset(seed=0)
    env.step(Action.DOWN)
    doc = WarehousePhysicsEnv.__doc__
    for field in dataclasses.fields(PhysicsConfig):
        assert f"``{field.name}``" in doc, field.name
    with pytest.raises(TypeError, match="unexpected keyword argument 'radius'"):
        gym.make(PHYS_ID, radius=0.2)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"cell_size": -1.0}, "cell_size must be positive"),
        ({"robot_radius": 0.6}, "must be less than half the cell_size"),
        ({"dt": 0.5}, "longer than move_duration"),
        ({"max_speed": 30.0}, "could pass through a wall"),
    ],
)
def test_nonsense_physics_is_refused_through_make(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(PHYS_ID, **kwargs)


def test_path_recording_follows_the_render_mode_unless_told():
    assert gym.make(PHYS_ID).unwrapped.record_path is False
    assert gym.make(PHYS_ID, render_mode="ansi").unwrapped.record_path is False
    assert gym.make(PHYS_ID, render_mode="rgb_array").unwrapped.record_path is True
    assert gym.make(PHYS_ID, record_path=True).unwrapped.record_path is True
    with pytest.raises(ValueError, match="record_path must be on"):
        gym.make(PHYS_ID, render_mode="human", record_path=False)
    with pytest.raises(TypeError, match="record_path must be a bool or None"):
        gym.make(PHYS_ID, record_path="yes")


def test_last_move_path_is_documented_and_guarded():
    env = WarehousePhysicsEnv(record_path=True)
    with pytest.raises(ResetNeeded):
        _ = env.last_move_path
    env.reset(options={"target": (2, 2)})
    assert env.last_move_path.shape == (0, 2)
    env.step(Action.RIGHT)
    path = env.last_move_path
    assert path.shape == (15, 2)
    assert path[-1] == pytest.approx((0, 1), abs=SNAP_ERROR_BOUND)
    silent = WarehousePhysicsEnv()
    silent.reset(seed=0)
    silent.step(Action.RIGHT)
    with pytest.raises(RuntimeError, match="record_path=True"):
        _ = silent.last_move_path


def test_render_fps_plays_a_default_move_in_real_time():
    physics = PhysicsConfig()
    assert WarehousePhysicsEnv.metadata["render_fps"] * physics.dt == pytest.approx(1.0)


# ------------------------------------------------------------------ rendering
def test_a_frame_in_the_middle_of_a_move_shows_the_robot_between_two_cells():
    env = gym.make(PHYS_ID, render_mode="rgb_array")
    env.reset(options={"target": (2, 2)})
    env.step(Action.RIGHT)
    frames = env.unwrapped.move_frames()
    assert len(frames) == 15
    assert all(f.shape == frames[0].shape and f.dtype == np.uint8 for f in frames)
    row, col = robot_centre(frames[len(frames) // 2])
    assert row == pytest.approx(0, abs=0.05)
    assert 0.2 < col < 0.8
    # The columns the robot is drawn at follow the recorded path.
    drawn = [robot_centre(f)[1] for f in frames]
    recorded = env.unwrapped.last_move_path[:, 1]
    assert np.abs(np.array(drawn) - recorded).max() < 0.05


def test_the_frame_after_a_move_equals_the_grid_twins_frame():
    frames = {}
    for env_id in (GRID_ID, PHYS_ID):
        env = gym.make(env_id, render_mode="rgb_array")
        env.reset(options={"target": (3, 4)})
        for action in [Action.RIGHT, Action.DOWN, Action.LEFT, Action.LEFT, Action.DOWN]:
            env.step(action)
        frames[env_id] = env.render()
    assert np.array_equal(frames[GRID_ID], frames[PHYS_ID])


def test_move_frames_need_no_render_mode_only_a_recorded_path():
    env = gym.make(PHYS_ID, record_path=True)
    env.reset(seed=0)
    env.step(Action.DOWN)
    assert len(env.unwrapped.move_frames()) == 15


def test_human_mode_plays_each_move_then_shows_the_snapped_frame(monkeypatch):
    env = gym.make(PHYS_ID, render_mode="human")
    env.reset(options={"target": (2, 2)})
    shown = []
    renderer = env.unwrapped._renderer
    original = renderer.show

    def spy(robot, target, status="", fps=None):
        shown.append(tuple(float(v) for v in robot))
        return original(robot, target, status, fps)

    monkeypatch.setattr(renderer, "show", spy)
    env.step(Action.DOWN)
    # move_duration * render_fps = 15 frames: 14 of the motion, then the snapped one.
    assert len(shown) == 15
    rows = [r for r, _ in shown]
    assert rows == sorted(rows)
    assert 0.0 < rows[5] < 1.0
    assert shown[-1] == (1.0, 0.0)
    env.close()


def test_human_playback_resamples_a_longer_move_to_real_time(monkeypatch):
    # 0.5 s moves at dt = 1/120 s: 60 physics steps, played as 30 frames at 60 fps.
    env = gym.make(PHYS_ID, render_mode="human", move_duration=0.5, dt=1 / 120, max_speed=6.0)
    env.reset(options={"target": (2, 2)})
    shown = []
    renderer = env.unwrapped._renderer
    original = renderer.show
    monkeypatch.setattr(
        renderer, "show", lambda robot, *a, **k: shown.append(robot) or original(robot, *a, **k)
    )
    env.step(Action.RIGHT)
    assert len(shown) == 30
    env.close()


RESTART_SETTINGS = [  # each accepted by check_controller
    {},
    {"max_force": 9000.0, "robot_mass": 12.0},
    {"robot_radius": 0.2, "max_speed": 9.0, "max_force": 6000.0},
    {"robot_radius": 0.35, "max_speed": 5.0, "max_force": 5000.0},
    {"dt": 1 / 120},
]


@settings(max_examples=60)
@given(
    setting=st.sampled_from(RESTART_SETTINGS),
    layout=st.sampled_from([None, "maze"]),
    history=st.lists(st.sampled_from(list(Action)), min_size=1, max_size=40),
    episodes=st.integers(1, 3),
    seed=st.integers(0, 1000),
    replay=st.lists(st.sampled_from(list(Action)), min_size=1, max_size=25),
)
def test_an_episode_after_any_history_replays_bit_for_bit_in_a_new_world(
    setting, layout, history, episodes, seed, replay
):
    """Reset keeps the walls and swaps in a new robot: nothing of the past may show."""
    kwargs = {"layout": layout, "record_path": True, **setting}
    used = WarehousePhysicsEnv(**kwargs)
    used.reset(seed=seed)
    for _ in range(episodes):  # bumps, contacts and warm starts, then a reset
        for action in history:
            used.step(action)
        used.reset()
    target = tuple(int(v) for v in used._target)
    fresh = WarehousePhysicsEnv(**kwargs)
    fresh.reset(options={"target": target})
    for action in replay:
        a, b = used.step(action), fresh.step(action)
        assert np.array_equal(a[0], b[0])
        assert a[4] == b[4]
        assert used.last_move_path.tobytes() == fresh.last_move_path.tobytes()


def test_a_duration_is_not_a_physical_setting():
    with pytest.raises(TypeError, match=r"^dt must be a real number, got np.timedelta64\(1\)"):
        gym.make(PHYS_ID, dt=np.timedelta64(1))
