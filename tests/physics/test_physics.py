"""The pymunk world and its controller on their own, without an environment."""

import dataclasses
import math

import numpy as np
import pymunk
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.physics import (
    PENETRATION_TOLERANCE,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
    PhysicsWorld,
    check_controller,
    penetration,
    speed_profile,
)
from warehouse_phys.world.grid import Action, WarehouseGrid

DEFAULTS = PhysicsConfig()
GRID = WarehouseGrid(3, 3)
CENTRE = (1, 1)
NEIGHBOURS = {Action.LEFT: (1, 0), Action.DOWN: (2, 1), Action.RIGHT: (1, 2), Action.UP: (0, 1)}
# From the middle of the top-left cell, the two actions that run into a wall.
INTO_WALL_FROM_CORNER = (Action.LEFT, Action.UP)


def world(config=DEFAULTS, start=CENTRE, grid=GRID, **kwargs):
    return PhysicsWorld(grid, config, start, **kwargs)


def body_cell_units(w):
    x, y = w.robot.position
    size = w.config.cell_size
    return y / size - 0.5, x / size - 0.5


# ---------------------------------------------------------------------- config
def test_default_clocks_give_fifteen_steps_a_move():
    assert DEFAULTS.steps_per_move == 15
    assert DEFAULTS.settle_steps == 6
    assert DEFAULTS.dt == pytest.approx(1 / 60)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"cell_size": 0.0}, "cell_size must be positive"),
        ({"robot_mass": -1.0}, "robot_mass must be positive"),
        ({"max_force": math.nan}, "max_force must be positive and finite"),
        ({"gain": math.inf}, "gain must be positive and finite"),
        ({"robot_radius": 0.5}, "robot_radius 0.5 m must be less than half the cell_size"),
        ({"robot_radius": 0.7}, "the robot must fit in a cell"),
        ({"dt": 0.5}, "dt 0.5 s is longer than move_duration"),
        ({"dt": 0.07}, "not a whole number of dt=0.07 s steps"),
        ({"settle_time": 0.25}, "settle_time 0.25 s must be at least one step"),
        ({"settle_time": 0.001}, "settle_time 0.001 s must be at least one step"),
        ({"max_speed": 20.0}, "could pass through a wall"),
    ],
)
def test_nonsense_configuration_is_refused_with_the_reason(changes, message):
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(DEFAULTS, **changes)


@pytest.mark.parametrize("value", ["1.0", None, True])
def test_non_numbers_are_refused(value):
    with pytest.raises(TypeError, match="robot_mass must be a real number"):
        PhysicsConfig(robot_mass=value)


def test_defaults_pass_the_controller_check():
    # The default controller brings the robot to rest without passing its aim.
    assert check_controller(DEFAULTS) == (0.0, 0.0, 0.0)


def test_the_controller_check_measures_how_far_moves_run_past_their_aims():
    config = PhysicsConfig(max_speed=7.0, gain=100.0, max_force=2000.0, move_duration=0.5,
                           settle_time=0.15)  # fmt: skip
    motion = check_controller(config)
    world = PhysicsWorld(WarehouseGrid(5, 5), config, (2, 2), record_path=True)
    world.move(Action.RIGHT)
    assert motion.overshoot == pytest.approx(world.last_path[:, 1].max() - 3, abs=1e-9)
    world = PhysicsWorld(WarehouseGrid(5, 5), config, (2, 4), record_path=True)
    world.move(Action.RIGHT)  # a bump into the right wall, and back past the centre
    assert motion.bump_overshoot == pytest.approx(4 - world.last_path[:, 1].min(), abs=1e-9)
    assert motion.overshoot > 0.1
    assert motion.bump_overshoot > 0.01
    assert motion.drift < 1e-12  # moves run along their axis


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"max_force": 20.0}, r"a free move from \(2, 2\) \(LEFT\) ends on \(2, 2\), not \(2, 1\)"),
        (
            {"gain": 10.0},
            r"a free move from \(2, 2\) \(LEFT\) ends 0.128 cells from the centre, "
            "not within half the bound of 0.02",
        ),
        ({"settle_time": 1 / 60}, "a bump into a wall or shelf .* ends .* cells from the centre"),
    ],
)
def test_controller_check_refuses_a_controller_that_cannot_finish_a_move(changes, message):
    config = dataclasses.replace(DEFAULTS, **changes)
    with pytest.raises(ValueError, match=message):
        check_controller(config)


# ------------------------------------------------------------------ controller
@pytest.mark.parametrize("action", list(Action))
def test_one_move_from_rest_ends_within_the_bound_of_the_next_centre(action):
    w = world(record_path=True)
    result = w.move(action)
    assert result.cell == NEIGHBOURS[action]
    assert 0 <= result.snap_error < SNAP_ERROR_BOUND
    # The pre-snap position really was that close: the last recorded point.
    last = w.last_path[-1]
    assert math.dist(last, NEIGHBOURS[action]) == pytest.approx(result.snap_error, abs=1e-12)
    # ... and after the snap the body rests exactly on the centre.
    assert body_cell_units(w) == NEIGHBOURS[action]
    assert tuple(w.robot.velocity) == (0.0, 0.0)


@pytest.mark.parametrize("action", INTO_WALL_FROM_CORNER)
def test_a_move_into_a_wall_bumps_it_and_returns_to_its_own_centre(action):
    w = world(start=(0, 0), record_path=True)
    result = w.move(action)
    assert result.cell == (0, 0)
    assert result.snap_error < SNAP_ERROR_BOUND
    path = w.last_path
    along = path[:, 1] if action == Action.LEFT else path[:, 0]  # towards the wall: negative
    gap = 0.5 - DEFAULTS.robot_radius / DEFAULTS.cell_size  # centre to wall, less the radius
    # It visibly drives towards the wall until the wall stops it...
    assert along.min() < -0.8 * gap
    # ... and the wall stops it: at most one step's travel of overlap, never through.
    overlap_allowed = DEFAULTS.max_speed * DEFAULTS.dt / DEFAULTS.cell_size
    assert along.min() > -(gap + overlap_allowed)
    # The other coordinate never moves: a straight bump, no slide along the wall.
    across = path[:, 0] if action == Action.LEFT else path[:, 1]
    assert np.abs(across).max() < 1e-9


def controller_trace(w, action):
    """Run a move while recording, after each physics step, speed and joint force."""
    speeds, forces = [], []
    step, handle = w._stepping()  # the move's own stepping function, wrapped to look inside

    def recording_step(space, dt):
        step(handle, dt)
        speeds.append(abs(w.robot.velocity))
        forces.append(w.joint.impulse / dt)

    w._stepping = lambda: (recording_step, w.space)
    w.move(action)
    return np.array(speeds), np.array(forces)


@pytest.mark.parametrize(("start", "action"), [(CENTRE, Action.RIGHT), ((0, 0), Action.UP)])
def test_speed_and_force_stay_within_their_limits(start, action):
    w = world(start=start)
    speeds, forces = controller_trace(w, action)
    assert len(speeds) == DEFAULTS.steps_per_move
    assert speeds.max() <= DEFAULTS.max_speed * (1 + 1e-9)
    assert forces.max() <= DEFAULTS.max_force * (1 + 1e-9)
    # The limits are reached, so they are what shapes the motion.
    assert speeds.max() > 0.9 * DEFAULTS.max_speed
    assert forces.max() > 0.9 * DEFAULTS.max_force


def test_a_controller_too_weak_to_arrive_leaves_the_robot_short():
    weak = dataclasses.replace(DEFAULTS, max_force=20.0)  # 1 m/s^2 on 20 kg: 3 cm in 0.25 s
    w = world(weak, record_path=True)
    result = w.move(Action.RIGHT)
    assert result.cell == CENTRE  # read from the body, which never got there
    assert w.last_path[:, 1].max() - CENTRE[1] < 0.1


def test_moves_chain_from_snapped_rest_states():
    w = world(start=(0, 0))
    cells = [w.move(action).cell for action in [Action.RIGHT, Action.RIGHT, Action.DOWN] * 2]
    assert cells == [(0, 1), (0, 2), (1, 2), (1, 2), (1, 2), (2, 2)]


# --------------------------------------------------------------- determinism
def paths(w, actions):
    out = []
    for action in actions:
        w.move(action)
        out.append(w.last_path)
    return np.concatenate(out)


@given(
    actions=st.lists(st.sampled_from(list(Action)), min_size=1, max_size=30),
    start=st.tuples(st.integers(0, 2), st.integers(0, 2)),
)
def test_fresh_worlds_replay_bit_for_bit(actions, start):
    first = paths(world(start=start, record_path=True), actions)
    second = paths(world(start=start, record_path=True), actions)
    assert first.tobytes() == second.tobytes()


def test_fast_stepping_equals_pymunks_space_step():
    actions = np.random.default_rng(3).integers(4, size=60).tolist()
    fast = world(start=(0, 0), record_path=True)
    plain = world(start=(0, 0), record_path=True)
    plain._stepping = lambda: (pymunk.Space.step, plain.space)  # the public, checked call
    assert paths(fast, actions).tobytes() == paths(plain, actions).tobytes()


# ----------------------------------------------------------------- recording
def test_path_has_one_point_per_physics_step_in_cell_units():
    w = world(record_path=True)
    assert w.last_path.shape == (0, 2)
    w.move(Action.DOWN)
    path = w.last_path
    assert path.shape == (DEFAULTS.steps_per_move, 2)
    assert path.dtype == np.float64
    assert np.all(np.diff(path[:, 0]) >= 0)  # only ever towards the next row
    # chipmunk moves bodies with the velocity they had before the step: the first
    # step only accelerates, the second one moves.
    assert path[0].tolist() == list(CENTRE)
    assert path[1, 0] > CENTRE[0]
    assert path[-1] == pytest.approx(NEIGHBOURS[Action.DOWN], abs=SNAP_ERROR_BOUND)
    path[:] = 0  # a copy: the world's record is untouched
    assert w.last_path[-1] == pytest.approx(NEIGHBOURS[Action.DOWN], abs=SNAP_ERROR_BOUND)


def test_path_is_in_cell_units_whatever_the_cell_size():
    # Every length, speed and force doubled: the same motion, measured in cells.
    doubled = dataclasses.replace(
        DEFAULTS, cell_size=2.0, robot_radius=0.6, max_speed=12.0, max_force=6000.0
    )
    big, small = world(doubled, record_path=True), world(record_path=True)
    big.move(Action.RIGHT)
    small.move(Action.RIGHT)
    assert big.last_path == pytest.approx(small.last_path, abs=1e-9)
    assert big.last_path[-1] == pytest.approx(NEIGHBOURS[Action.RIGHT], abs=SNAP_ERROR_BOUND)


def test_reading_the_path_without_recording_says_how_to_turn_it_on():
    w = world()
    w.move(Action.DOWN)
    with pytest.raises(RuntimeError, match="record_path=True"):
        _ = w.last_path


# ------------------------------------------------------------------ the world
def test_walls_are_static_and_the_robot_is_a_real_dynamic_body():
    w = world()
    assert w.space.threads == 1
    assert w.robot.body_type == pymunk.Body.DYNAMIC
    assert w.robot.mass == pytest.approx(DEFAULTS.robot_mass)
    expected_moment = pymunk.moment_for_circle(DEFAULTS.robot_mass, 0, DEFAULTS.robot_radius)
    assert w.robot.moment == pytest.approx(expected_moment)
    walls = [s for s in w.space.shapes if s.body.body_type == pymunk.Body.STATIC]
    assert len(walls) == 4
    assert w.control.body_type == pymunk.Body.KINEMATIC
    assert w.joint.max_force == DEFAULTS.max_force
    assert w.joint.max_bias == DEFAULTS.max_speed


def test_start_off_the_floor_is_refused():
    with pytest.raises(ValueError, match=r"start \(3, 0\) is off the 3x3 floor"):
        world(start=(3, 0))


def test_a_body_that_left_the_floor_is_reported_not_snapped():
    w = world(start=(0, 0))
    w.robot.position = (-5.0, 0.5)  # as if it had tunnelled through the left wall
    with pytest.raises(RuntimeError, match="left the floor"):
        w.move(Action.UP)


# -------------------------------------------------------------------- shelves
SHELVED = WarehouseGrid.from_layout(["S.#", "...", "#.."])


@pytest.mark.parametrize(("start", "action"), [((0, 1), Action.RIGHT), ((1, 0), Action.DOWN)])
def test_a_move_into_a_shelf_bumps_it_and_returns(start, action):
    w = world(start=start, grid=SHELVED, record_path=True)
    result = w.move(action)
    assert result.cell == start
    assert result.snap_error < SNAP_ERROR_BOUND
    path = w.last_path
    axis = 1 if action == Action.RIGHT else 0
    towards = path[:, axis] - start[axis]  # positive: towards the shelf
    gap = 0.5 - DEFAULTS.robot_radius / DEFAULTS.cell_size
    overlap_allowed = DEFAULTS.max_speed * DEFAULTS.dt / DEFAULTS.cell_size
    assert towards.max() > 0.8 * gap  # it drove up to the shelf...
    assert towards.max() < gap + overlap_allowed  # ... which stopped it


def test_shelves_are_static_boxes_merged_along_rows():
    grid = WarehouseGrid.from_layout(["S.##.##", ".......", "###...#"])
    w = world(start=(0, 0), grid=grid)
    static = [s for s in w.space.shapes if s.body.body_type == pymunk.Body.STATIC]
    # pymunk's bounding boxes: x from left to right, y (our rows) from "bottom" to "top".
    boxes = sorted((s.bb.left, s.bb.bottom, s.bb.right, s.bb.top) for s in static[4:])
    # Row 0, columns 2-3 and 5-6; row 2, columns 0-2 and 6: four boxes, filling their cells.
    assert boxes == [(0, 2, 3, 3), (2, 0, 4, 1), (5, 0, 7, 1), (6, 2, 7, 3)]
    assert len(static) == 4 + 4


# --------------------------------------------------------------- speed profile
def test_speed_profile_is_the_distance_covered_in_each_step():
    w = world(record_path=True)
    velocities, _ = controller_trace(w, Action.RIGHT)
    times, speeds = speed_profile(CENTRE, w.last_path, DEFAULTS)
    assert times == pytest.approx(DEFAULTS.dt * np.arange(1, 16))
    # chipmunk moves a body with the velocity of the step before: the first step
    # starts from rest, each later one covers what the body's speed then was.
    assert speeds[0] == 0
    assert speeds[1:] == pytest.approx(velocities[:-1], rel=1e-9, abs=1e-9)
    assert speeds.max() <= DEFAULTS.max_speed * (1 + 1e-9)
    assert (speeds * DEFAULTS.dt).sum() == pytest.approx(DEFAULTS.cell_size, abs=0.01)


def test_speed_profile_is_in_metres_whatever_the_cell_size():
    config = dataclasses.replace(DEFAULTS, cell_size=2.0, robot_radius=0.6, max_speed=12.0,
                                 max_force=24000.0)  # fmt: skip
    w = world(config, record_path=True)
    w.move(Action.DOWN)
    _, speeds = speed_profile(CENTRE, w.last_path, config)
    assert (speeds * config.dt).sum() == pytest.approx(2.0, abs=0.02)


def test_speed_profile_refuses_a_path_of_the_wrong_shape():
    with pytest.raises(ValueError, match=r"path must have shape \(k, 2\), got \(3,\)"):
        speed_profile((0, 0), np.zeros(3), DEFAULTS)


# ------------------------------------------------------------------- lifetime
# Building and dropping worlds must never free a chipmunk space from inside another
# space's finalizer or step: chipmunk aborts the whole process when that happens.
# Each check runs in a fresh interpreter, so a crash fails the test instead of pytest.
CHECK_ENV_SCRIPT = """
import warnings, gymnasium as gym, warehouse_phys
from gymnasium.utils.env_checker import check_env
for env_id in ("warehouse-robot-v0", "warehouse-robot-phys-v0", "warehouse-robot-phys-maze-v0"):
    for rm in (None, "rgb_array", "ansi"):
        env = gym.make(env_id, render_mode=rm)
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            check_env(env.unwrapped, skip_render_check=False)
print("done")
"""

GC_STRESS_SCRIPT = """
import copy, gc, pickle
import gymnasium as gym
import warehouse_phys
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.physics import PhysicsConfig, PhysicsWorld, check_controller

gc.set_threshold(1, 1, 1)  # a collection at almost every allocation
grids = [WarehouseGrid(3, 3), WarehouseGrid.from_layout(["S.#", "...", "#.P"])]
ids = [
    "warehouse-robot-v0", "warehouse-robot-phys-v0",
    "warehouse-robot-maze-v0", "warehouse-robot-phys-maze-v0",
]
for i in range(1000):
    world = PhysicsWorld(grids[i % 2], PhysicsConfig(), (0, 0), record_path=i % 3 == 0)
    world.move(i % 4)
    del world
    if i % 20 == 0:
        check_controller(PhysicsConfig(max_force=3000.0 + i))  # probe worlds, built and dropped
    env = gym.make(ids[i % 4])
    env.reset(seed=i)
    env.step(i % 4)
    if i % 50 == 0:
        pickle.loads(pickle.dumps(env)).step(1)
        copy.deepcopy(env).step(2)
    env.reset()
    del env
print("done")
"""


@pytest.mark.slow
def test_check_env_on_every_kind_never_crashes_in_fresh_processes(tmp_path):
    import subprocess
    import sys

    script = tmp_path / "check_every_env.py"
    script.write_text(CHECK_ENV_SCRIPT)
    for _ in range(2):  # four runs, two at a time
        runs = [
            subprocess.Popen(
                [sys.executable, str(script)],
                cwd=tmp_path,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            for _ in range(2)
        ]
        for run in runs:
            out, err = run.communicate(timeout=120)
            assert run.returncode == 0, f"exit {run.returncode}: {err[-2000:]}"
            assert out.strip() == "done"


@pytest.mark.slow
def test_worlds_and_environments_survive_garbage_collection_at_every_allocation(run_python):
    assert run_python(GC_STRESS_SCRIPT, timeout=300).strip() == "done"


# ------------------------------------------------------- every accepted setting
@pytest.mark.parametrize(
    ("changes", "error", "message"),
    [
        # Found by trying settings as a user would: each is refused, saying why.
        ({"max_speed": 13.0}, ValueError, "ends .* cells from the centre, not within half"),
        ({"max_speed": 17.0}, ValueError, "ends .* cells from the centre, not within half"),
        ({"max_speed": 17.99}, ValueError, "ends .* cells from the centre, not within half"),
        (
            {"robot_radius": 0.15, "max_speed": 8.0, "max_force": 30000.0, "robot_mass": 5.0},
            ValueError,
            "cells into a wall or shelf, more than the tolerance of 0.1",
        ),
        ({"robot_mass": 10**400}, ValueError, "robot_mass is too large: an integer of 401 digits"),
        ({"cell_size": 1e308}, ValueError, "cell_size must be between 0.001 and 1000"),
        ({"dt": 1e-308}, ValueError, "dt must be between 1e-05 and 1"),
        ({"dt": 1e-4}, ValueError, "2500 steps .* more than the 1000 a move may take"),
        ({"gain": np.complex128(60)}, TypeError, "gain must be a real number"),
        ({"max_force": np.bool_(True)}, TypeError, "max_force must be a real number"),
    ],
)
def test_settings_that_would_break_a_promise_are_refused(changes, error, message):
    with pytest.raises(error, match=message):
        check_controller(dataclasses.replace(DEFAULTS, **changes))


def test_settings_are_stored_as_plain_floats():
    config = PhysicsConfig(robot_mass=np.int64(20), gain=np.float32(60))
    assert type(config.robot_mass) is float
    assert config.robot_mass == 20.0
    assert type(config.gain) is float
    assert config.gain == 60.0


def run_and_check(config, grid, actions):
    """Play ``actions`` from the start; assert every promise at every move and physics step."""
    world = PhysicsWorld(grid, config, grid.start, record_path=True)
    cell, paths = grid.start, []
    for action in actions:
        result = world.move(action)
        cell = grid.move(cell, action)
        assert result.cell == cell
        assert result.snap_error < SNAP_ERROR_BOUND
        paths.append(world.last_path)
    depth = penetration(grid, config.robot_radius / config.cell_size, np.concatenate(paths))
    assert depth.max() <= PENETRATION_TOLERANCE


def orders(default, spread):
    """A value ``spread`` orders of magnitude either side of ``default``, log-uniformly."""
    return st.floats(-spread, spread).map(lambda e: float(default * 10**e))


@st.composite
def physics_settings(draw):
    spread = draw(st.sampled_from([2.0, 0.5]))  # wide, or close to the defaults
    values = {
        name: draw(orders(getattr(DEFAULTS, name), spread))
        for name in ("cell_size", "robot_mass", "floor_damping", "max_speed", "max_force", "gain")
    }
    values["robot_radius"] = values["cell_size"] * draw(st.floats(0.01, 0.6))
    dt = draw(orders(DEFAULTS.dt, spread / 2))
    steps = draw(st.integers(1, 60))
    values.update(dt=dt, move_duration=dt * steps, settle_time=dt * draw(st.integers(0, steps)))
    return values


MAZE = WarehouseGrid.from_layout(["S.#....", "..#.##.", "..#..#.", "....##.", "###...."])


@pytest.mark.slow
@settings(max_examples=300)
@given(values=physics_settings(), seed=st.integers(0, 2**32 - 1))
def test_every_accepted_setting_keeps_every_promise(values, seed):
    """Refused with ValueError or TypeError, or 1200 random actions on two floors keep
    the snap bound, the grid rules and the penetration tolerance at every physics step."""
    try:
        config = PhysicsConfig(**values)
        check_controller(config)
    except (ValueError, TypeError):
        return
    rng = np.random.default_rng(seed)
    for grid in (WarehouseGrid(4, 5), MAZE):
        run_and_check(config, grid, rng.integers(4, size=1200).tolist())


@pytest.mark.parametrize("grid", [WarehouseGrid(4, 5), MAZE], ids=["empty", "maze"])
def test_the_defaults_keep_every_promise_at_every_physics_step(grid):
    run_and_check(DEFAULTS, grid, np.random.default_rng(0).integers(4, size=3000).tolist())
