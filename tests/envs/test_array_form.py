"""Actions in array form are checked as the dicts' are: one line naming the robot."""

import numpy as np
import pytest

from warehouse_phys.envs.array_form import action_array, info_dicts

NAMES = "0 (STOP) or 1 (GO)"


@pytest.mark.parametrize(
    ("actions", "expected"),
    [
        (np.array([0, 1, 1]), [0, 1, 1]),
        (np.array([0, 1, 1], dtype=np.uint8), [0, 1, 1]),
        (np.array([1, 0, 1], dtype=">i2"), [1, 0, 1]),
        ([1, np.int8(0), np.array(1)], [1, 0, 1]),
        ((0, 0, 0), [0, 0, 0]),
    ],
)
def test_integer_arrays_and_lists_are_taken(actions, expected):
    checked = action_array(actions, 3, 2, NAMES)
    assert checked.dtype == np.int64
    assert checked.tolist() == expected


@pytest.mark.parametrize(
    ("actions", "error", "message"),
    [
        (np.array([0, 1, 2]), ValueError, r"actions must be 0 \(STOP\) or 1 \(GO\): robot_2 got 2"),
        (np.array([0, -1, 1]), ValueError, "robot_1 got -1"),
        (np.array([0, 1]), ValueError, r"must have shape \(3,\), one a robot, got shape \(2,\)"),
        (np.array([True, False, True]), TypeError, "got dtype bool"),
        (np.array([0.0, 1.0, 1.0]), TypeError, "got dtype float64"),
        (np.array([0, 1, 1], dtype="m8[s]"), TypeError, "got dtype timedelta64"),
        ([0, 1, 10**400], ValueError, "robot_2 got an integer of 1329 bits"),
        ([0, True, 1], TypeError, "robot_1 got True"),
        ([0, 1.0, 1], TypeError, "robot_1 got 1.0"),
        (np.ma.masked_array([0, 1, 1], mask=[0, 0, 1]), ValueError, "robot_2's action is masked"),
        ({"robot_0": 1}, TypeError, "actions must be an array of 3 integers, got dict"),
    ],
)
def test_bad_actions_are_refused_naming_the_robot(actions, error, message):
    with pytest.raises(error, match=message):
        action_array(actions, 3, 2, NAMES)


def test_info_dicts_hold_python_numbers_in_key_order():
    infos = info_dicts(["a", "b"], {"x": np.array([1, 2]), "y": np.array([0.5, 1.5])})
    assert infos == {"a": {"x": 1, "y": 0.5}, "b": {"x": 2, "y": 1.5}}
    assert type(infos["a"]["x"]) is int
