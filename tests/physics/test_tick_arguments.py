"""A tick's arguments checked against the batched world: one-line errors naming them."""

import numpy as np
import pytest

from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.world.grid import WarehouseGrid

CONFIG = PhysicsConfig()
FLOOR = WarehouseGrid.from_layout(["......", ".#..#.", ".#..#.", "......", "..##..", "......"])


#: Two robots, the first beside a shelf (below it).
START_PAIR = [[0, 1], [3, 0]]


def bad_tick(world, **changes):
    n = world.n_robots
    arguments = {"left": world.cells.copy(), "entered": world.cells + np.array([0, 1]),
                 "before": np.zeros(n), "after": np.full(n, 0.5),
                 "ended": np.zeros(n, dtype=bool), "tick_steps": 3}  # fmt: skip
    arguments.update(changes)
    return world.drive_tick(**arguments)


@pytest.mark.parametrize(
    ("changes", "error", "name"),
    [
        ({"left": np.zeros((2, 2))}, TypeError, "left"),
        ({"left": np.zeros((3, 2), dtype=int)}, ValueError, "left"),
        ({"left": np.array([[0, 2], [3, 0]])}, ValueError, "left"),
        ({"entered": np.array([[1, 2], [3, 1]])}, ValueError, "entered"),  # diagonal
        ({"entered": np.array([[1, 1], [3, 1]])}, ValueError, "entered"),  # a shelf
        ({"entered": np.array([[-1, 1], [3, 1]])}, ValueError, "entered"),  # off the floor
        ({"entered": np.array([[0, 2]])}, ValueError, "entered"),
        ({"before": np.array([-0.1, 0.0])}, ValueError, "before"),
        ({"before": np.array([0.1, 0.0])}, ValueError, "before"),  # not where it was
        ({"before": np.zeros(3)}, ValueError, "before"),
        ({"before": np.array(["a", "b"])}, TypeError, "before"),
        ({"after": np.array([1.5, 0.5])}, ValueError, "after"),
        ({"after": np.array([np.nan, 0.5])}, ValueError, "after"),
        ({"ended": np.array([True, False])}, ValueError, "ended"),
        ({"ended": np.array([1, 0])}, TypeError, "ended"),
        ({"ended": np.zeros(3, dtype=bool)}, ValueError, "ended"),
        ({"after": np.array([1.0, 0.5])}, ValueError, "ended"),  # done, but not ended
        ({"tick_steps": 0}, ValueError, "tick_steps"),
        ({"tick_steps": 2.0}, TypeError, "tick_steps"),
    ],
)
def test_bad_arguments_get_one_line_errors_naming_them(changes, error, name):
    world = BatchedPhysicsWorld(FLOOR, CONFIG, START_PAIR)
    with pytest.raises(error) as raised:
        bad_tick(world, **changes)
    assert str(raised.value).startswith(name)
    assert "\n" not in str(raised.value)


def test_a_robot_in_mid_move_must_go_on_where_it_was_going():
    world = BatchedPhysicsWorld(FLOOR, CONFIG, START_PAIR)
    bad_tick(world)  # both robots halfway into the cell to their right
    with pytest.raises(ValueError, match=r"^entered: robot 0 is in mid-move into \(0, 2\)"):
        bad_tick(world, entered=np.array([[0, 0], [3, 1]]), before=np.full(2, 0.5))
    world = BatchedPhysicsWorld(FLOOR, CONFIG, START_PAIR)
    with pytest.raises(ValueError, match=r"^after: robot 0 has no move"):
        bad_tick(world, entered=np.array([[0, 1], [3, 1]]))


def bad_turning_tick(world, **changes):
    n = world.n_robots
    arguments = {"left": world.cells.copy(), "entered": world.cells.copy(),
                 "before": np.zeros(n), "after": np.full(n, 0.5),
                 "ended": np.zeros(n, dtype=bool), "tick_steps": 3,
                 "headings_before": np.zeros(n, dtype=int),
                 "headings_after": np.array([1, 3])}  # fmt: skip
    arguments.update(changes)
    arguments = {name: value for name, value in arguments.items() if value is not None}
    return world.drive_tick(**arguments)


@pytest.mark.parametrize(
    ("turning", "changes", "error", "name"),
    [
        (True, {"headings_before": None}, TypeError, "headings_before"),
        (True, {"headings_after": None}, TypeError, "headings_after"),
        (False, {}, TypeError, "headings_before"),  # given to robots that do not turn
        (False, {"headings_before": None}, TypeError, "headings_after"),
        (True, {"headings_before": np.zeros(2)}, TypeError, "headings_before"),
        (True, {"headings_after": np.zeros(3, dtype=int)}, ValueError, "headings_after"),
        (True, {"headings_after": np.array([4, 0])}, ValueError, "headings_after"),
        (True, {"headings_before": np.array([1, 0])}, ValueError, "headings_before"),  # faces 0
        (True, {"headings_after": np.array([2, 3])}, ValueError, "headings_after"),  # half turn
        (True, {"entered": np.array([[0, 2], [3, 0]])}, ValueError, "entered"),  # turns and moves
        (
            True,
            {"headings_after": np.zeros(2, int), "entered": np.array([[0, 2], [2, 0]])},
            ValueError,
            "entered",
        ),  # robot 1 faces east, moves north
        (True, {"headings_after": np.array([0, 3])}, ValueError, "after"),  # robot 0 does nothing
    ],
)
def test_bad_turning_arguments_get_one_line_errors_naming_them(turning, changes, error, name):
    world = BatchedPhysicsWorld(FLOOR, CONFIG, START_PAIR, headings=[0, 0] if turning else None)
    if not turning:
        changes = {"entered": world.cells + np.array([0, 1]), **changes}
    with pytest.raises(error) as raised:
        bad_turning_tick(world, **changes)
    assert str(raised.value).startswith(name)
    assert "\n" not in str(raised.value)
