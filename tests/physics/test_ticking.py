"""The physics twin of asynchronous execution: bodies follow their nominal positions tick
by tick, end on the grid twin's cells, and keep the clearance the module derives (the
check that measures it: test_tick_controller.py; a tick's arguments: test_tick_arguments.py)."""

import copy
import inspect

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from warehouse_phys.execution.async_grid import AsyncGrid
from warehouse_phys.execution.executor import Executor
from warehouse_phys.execution.windows import pibt_window
from warehouse_phys.physics import (
    COLLISION_SLOP,
    HEADING_SNAP_BOUND,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
)
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.tick_controller import check_tick_controller, required_min_gap
from warehouse_phys.physics.ticking import (
    HEADING_STEPS,
    QUARTER,
    angle_errors,
    default_tick_steps,
    nominal_angles,
    nominal_positions,
    tick_fractions,
    tracking_errors,
)
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import TurnAction, turned
from warehouse_phys.world.traffic import neighbour_table

CONFIG = PhysicsConfig()
FLOOR = WarehouseGrid.from_layout(["......", ".#..#.", ".#..#.", "......", "..##..", "......"])


def rows_cols(cells, cols=FLOOR.cols):
    return np.stack(np.divmod(cells, cols), axis=1)


def tick_on(world, twin, go, heading, delayed, tick_steps):
    """Step the grid twin (an AsyncGrid) and drive the bodies through the same tick; the
    tick's arguments to drive_tick and what it returned."""
    left, done = rows_cols(twin.left), twin.done.copy()
    ended = twin.step(go, heading, delayed)
    entered = rows_cols(twin.entered)
    before, after = tick_fractions(done, twin.done, ended, twin.ticks_needed)
    cells, snaps = world.drive_tick(left, entered, before, after, ended, tick_steps)
    return (left, entered, before, after, ended), cells, snaps


def random_heading(twin, table, rng):
    """At rest: a random free neighbour (or the robot's own cell); in mid-move: its move's."""
    pick = table[twin.left, rng.integers(table.shape[1], size=len(twin.left))]
    return np.where(twin.done > 0, twin.entered, pick)


@pytest.mark.parametrize("ticks", [1, 3, 10])
def test_bodies_follow_their_nominal_positions_within_e_at_every_physics_step(ticks):
    steps = default_tick_steps(CONFIG, ticks)
    motion = check_tick_controller(CONFIG, ticks, steps)
    rng = np.random.default_rng(ticks)
    n = 10
    free = np.flatnonzero(FLOOR.free_mask.ravel())
    starts = rng.choice(free, n)  # one floor each: the twin may put two robots on a cell
    needed = ticks + rng.integers(0, 2 * ticks + 1, size=n)  # from T to 3T ticks a move
    twin = AsyncGrid(FLOOR, starts, needed)
    world = BatchedPhysicsWorld(FLOOR, CONFIG, rows_cols(starts), record_path=True)
    table = neighbour_table(FLOOR)
    worst, ended_moves = 0.0, 0
    for _ in range(60 * ticks):
        go = rng.random(n) < 0.7
        heading = random_heading(twin, table, rng)
        tick, cells, snaps = tick_on(world, twin, go, heading, None, steps)
        left, entered, before, after, ended = tick
        off, _ = tracking_errors(world.last_paths, left, entered, before, after)
        worst = max(worst, float(off.max()))
        assert off.max() <= motion.tracking_error + 1e-12
        assert np.array_equal(cells, rows_cols(twin.left[ended]))
        assert (snaps < SNAP_ERROR_BOUND).all()
        ended_moves += int(ended.sum())
        at_rest = ~ended & (twin.done == 0)
        assert np.array_equal(world.cells, rows_cols(twin.left))
        assert np.allclose(world.positions()[at_rest], rows_cols(twin.left[at_rest]), atol=1e-9)
    assert ended_moves > 5 * n
    assert worst > 0.5 * motion.tracking_error  # the probes' error is met, not far off


def make_executor(grid, cells, ticks_needed, min_gap):
    """An Executor with ``min_gap`` if this Executor takes one (else its own rule)."""
    if "min_gap" in inspect.signature(Executor).parameters:
        return Executor(grid, cells, ticks_needed, min_gap=min_gap)
    return Executor(grid, cells, ticks_needed)


@st.composite
def physical_settings(draw):
    config = PhysicsConfig(
        robot_radius=draw(st.floats(0.15, 0.4)),
        robot_mass=draw(st.floats(5.0, 60.0)),
        floor_damping=draw(st.floats(0.2, 3.0)),
        max_speed=draw(st.floats(2.0, 8.0)),
        max_force=draw(st.floats(800.0, 8000.0)),
        gain=draw(st.floats(15.0, 120.0)),
    )
    ticks = draw(st.sampled_from([1, 2, 3, 5, 10]))
    extra = draw(st.one_of(st.none(), st.integers(-1, 4)))  # steps a tick beyond the default
    steps = None if extra is None else max(1, default_tick_steps(config, ticks) + extra)
    return config, ticks, steps


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(setting=physical_settings(), seed=st.integers(0, 2**16), robots=st.integers(4, 12))
def test_executed_plans_keep_bodies_apart_and_on_the_grid_twins_cells(setting, seed, robots):
    config, ticks, steps = setting
    try:
        gap = required_min_gap(config, ticks, steps)
    except ValueError:
        assume(False)
    steps = default_tick_steps(config, ticks) if steps is None else steps
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(FLOOR.free_mask.ravel())
    cells = rows_cols(rng.choice(free, robots, replace=False))
    needed = ticks + rng.integers(0, ticks + 1, size=robots)
    executor = make_executor(FLOOR, cells, needed, gap)
    assert gap <= getattr(executor, "min_gap", 1.0)
    twin = AsyncGrid(FLOOR, cells[:, 0] * FLOOR.cols + cells[:, 1], needed)
    one_floor = np.zeros(robots, dtype=np.int64)
    world = BatchedPhysicsWorld(FLOOR, config, cells, one_floor, record_path=True)
    e = check_tick_controller(config, ticks, steps).tracking_error
    planner = PIBT(FLOOR, corner_follows=False, seed=seed)
    goals = rows_cols(rng.choice(free, robots))
    least = config.robot_diameter - COLLISION_SLOP
    for tick in range(24 * ticks):
        if tick % ticks == 0:
            executor.add_plan(pibt_window(planner, executor.plan_cells(), goals, 1))
        delayed = rng.random(robots) < 0.15
        left, done = rows_cols(executor.left), executor.done.copy()
        report = executor.step(delayed)
        ended = twin.step(report.go, report.heading, delayed)
        assert np.array_equal(ended, report.ended)
        before, after = tick_fractions(done, executor.done, ended, needed)
        entered = rows_cols(executor.entered)
        read, _ = world.drive_tick(left, entered, before, after, ended, steps)
        assert np.array_equal(read, rows_cols(twin.left[ended]))
        off, _ = tracking_errors(world.last_paths, left, entered, before, after)
        assert off.max() <= e + 1e-12
        assert world.closest_approach().min() >= least
        arrived = ended & (executor.left == goals[:, 0] * FLOOR.cols + goals[:, 1])
        goals[arrived] = rows_cols(rng.choice(free, int(arrived.sum())))


def drive_right(world, twin, ticks):
    """Drive three robots right (to the floor's edge) tick by tick, each with its own
    GO pattern; their recorded paths."""
    paths = []
    for t in range(ticks):
        edge = twin.left % FLOOR.cols == FLOOR.cols - 1
        heading = np.where(twin.done > 0, twin.entered, np.where(edge, twin.left, twin.left + 1))
        tick_on(world, twin, np.array([True, t % 2 == 0, t % 3 != 0]), heading, None, 4)
        paths.append(world.last_paths)
    return np.concatenate(paths, axis=1)


def test_ticks_are_deterministic_and_a_copy_in_mid_move_goes_on_bit_for_bit():
    starts = np.array([[0, 0], [3, 0], [5, 0]])

    def fresh():
        world = BatchedPhysicsWorld(FLOOR, CONFIG, starts, np.zeros(3, int), record_path=True)
        return world, AsyncGrid(FLOOR, starts[:, 0] * FLOOR.cols + starts[:, 1], 3)

    (a, twin_a), (b, twin_b) = fresh(), fresh()
    assert np.array_equal(drive_right(a, twin_a, 10), drive_right(b, twin_b, 10))
    assert a.fractions.any()
    c, twin_c = copy.deepcopy(a), copy.deepcopy(twin_a)
    with pytest.raises(RuntimeError, match="mid-move"):
        a.move(a.cells)
    assert np.array_equal(drive_right(a, twin_a, 8), drive_right(c, twin_c, 8))


def test_a_robot_at_rest_holds_its_centre_and_an_ended_move_snaps_onto_the_centre():
    world = BatchedPhysicsWorld(FLOOR, CONFIG, [[0, 0], [3, 3]], [0, 0], record_path=True)
    zeros, none = np.zeros(2), np.zeros(2, dtype=bool)
    cells, snaps = world.drive_tick(world.cells, world.cells, zeros, zeros, none, 5)
    assert cells.shape == (0, 2)
    assert snaps.shape == (0,)
    assert np.array_equal(world.last_paths, np.broadcast_to([[[0, 0]], [[3, 3]]], (2, 5, 2)))
    entered = world.cells + np.array([[0, 1], [0, 0]])
    one_tick = np.array([1.0, 0.0])
    cells, snaps = world.drive_tick(world.cells, entered, zeros, one_tick, one_tick > 0, 40)
    assert np.array_equal(cells, [[0, 1]])
    assert snaps[0] < SNAP_ERROR_BOUND / 2
    assert np.array_equal(world.positions(), [[0, 1], [3, 3]])
    assert not world.fractions.any()
    world.move(world.cells)  # every robot at rest: a lock-step move may follow
    halfway = nominal_positions([[0, 0]], [[0, 1]], np.array([[0.25, 0.5]]))
    assert np.array_equal(halfway, [[[0, 0.25], [0, 0.5]]])


# ---------------------------------------------------------------------- turning robots
def random_actions(world, cells, facing, rng):
    """A random action for each robot: forward where the cell ahead is free, else (and
    otherwise at random) a quarter turn either way."""
    free_ahead = world.on_free_cells(cells + HEADING_STEPS[facing])
    pick = rng.integers(3, size=len(cells))  # FORWARD, CLOCKWISE, COUNTERCLOCKWISE
    return np.where(
        (pick == TurnAction.FORWARD) & ~free_ahead, rng.integers(1, 3, len(cells)), pick
    )


@pytest.mark.parametrize("ticks", [1, 3, 10])
def test_turning_bodies_follow_their_nominal_angles_and_centres_at_every_physics_step(ticks):
    steps = default_tick_steps(CONFIG, ticks)
    motion = check_tick_controller(CONFIG, ticks, steps, turning=True)
    rng = np.random.default_rng(ticks)
    n = 10
    cells = rows_cols(rng.choice(np.flatnonzero(FLOOR.free_mask.ravel()), n))  # a floor each
    facing = rng.integers(4, size=n)
    needed = ticks + rng.integers(0, 2 * ticks + 1, size=n)  # from T to 3T ticks an action
    world = BatchedPhysicsWorld(FLOOR, CONFIG, cells, record_path=True, headings=facing)
    action, done = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    worst, turns, moves = 0.0, 0, 0
    for _ in range(40 * ticks):
        action = np.where(done == 0, random_actions(world, cells, facing, rng), action)
        turned_to = turned(facing, action)
        forward = (action == TurnAction.FORWARD)[:, None]
        entered = np.where(forward, cells + HEADING_STEPS[facing], cells)
        advanced = done + (rng.random(n) < 0.7)  # GO or STOP
        ended = advanced == needed
        before, after = tick_fractions(done, np.where(ended, 0, advanced), ended, needed)
        read, snaps = world.drive_tick(
            cells, entered, before, after, ended, steps,
            headings_before=facing, headings_after=turned_to,
        )  # fmt: skip
        off, _ = tracking_errors(world.last_paths, cells, entered, before, after)
        angle = angle_errors(world.last_orientations, facing, turned_to, before, after)
        assert off.max() <= motion.tracking_error + 1e-12
        assert angle.max() <= motion.angle_error + 1e-12
        worst = max(worst, float(angle.max()))
        read_facing = np.rint(world.last_orientations[ended, -1]).astype(np.int64) % 4
        assert np.array_equal(read, entered[ended])
        assert np.array_equal(read_facing, turned_to[ended])
        assert np.array_equal(world.read_headings, read_facing)
        assert (snaps < SNAP_ERROR_BOUND / 2).all()
        assert (world.heading_errors < HEADING_SNAP_BOUND / 2).all()
        turns += int((ended & (turned_to != facing)).sum())
        moves += int((ended & forward[:, 0]).sum())
        cells = np.where(ended[:, None], entered, cells)
        facing, done = np.where(ended, turned_to, facing), np.where(ended, 0, advanced)
        assert np.array_equal(world.cells, cells)
        assert np.array_equal(world.headings, facing)
        rest = done == 0
        assert np.allclose(world.orientations()[rest], facing[rest], rtol=0, atol=1e-12)
        assert np.allclose(world.positions()[rest], cells[rest], rtol=0, atol=1e-9)
    assert turns > 3 * n
    assert moves > n
    assert worst > 0.5 * motion.angle_error  # the probes' error is met, not far off


def test_a_turn_stopped_halfway_goes_on_snaps_onto_its_heading_and_a_copy_follows():
    world = BatchedPhysicsWorld(FLOOR, CONFIG, [[3, 3]], record_path=True, headings=[0])
    here, east, north = np.array([[3, 3]]), np.array([0]), np.array([3])

    def turn_tick(world, before, after):  # a counter-clockwise turn, east to north
        fractions = np.array([before]), np.array([after])
        return world.drive_tick(here, here, *fractions, np.array([after == 1]), 10,
                                headings_before=east, headings_after=north)  # fmt: skip

    turn_tick(world, 0.0, 0.25)
    assert world.last_orientations.shape == (1, 10)
    assert world.orientations()[0] == pytest.approx(-0.25, abs=0.03)  # turning to -QUARTER
    with pytest.raises(ValueError, match=r"^headings_after: robot 0 is in mid-action"):
        world.drive_tick(here, here, np.array([0.25]), np.array([0.5]), np.array([False]), 10,
                         headings_before=east, headings_after=np.array([1]))  # fmt: skip
    turn_tick(world, 0.25, 0.25)  # STOP
    copy_ = copy.deepcopy(world)
    for w in (world, copy_):
        turn_tick(w, 0.25, 0.75)
        read, snaps = turn_tick(w, 0.75, 1.0)
    assert np.array_equal(world.last_orientations, copy_.last_orientations)
    assert np.array_equal(read, here)
    assert snaps[0] < 1e-9  # a turn holds the centre
    assert world.read_headings.tolist() == [3]
    assert world.heading_errors[0] < HEADING_SNAP_BOUND / 2
    assert world.headings.tolist() == [3]
    assert world.orientations()[0] == pytest.approx(3.0, abs=1e-12)  # snapped onto north
    assert np.array_equal(nominal_angles(east, north, np.array([1.0])), [-QUARTER])
    ahead, one = np.array([[2, 3]]), np.array([1.0])
    read, _ = world.drive_tick(here, ahead, np.zeros(1), one, one == 1, 40,
                               headings_before=north, headings_after=north)  # fmt: skip
    assert np.array_equal(read, ahead)
    assert np.array_equal(world.positions(), ahead)
