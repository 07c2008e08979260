"""Time in ticks: every robot's move takes ceil(ticks_per_move / speed) ticks, checked."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.execution.ticks import (
    LORR_TICKS_PER_MOVE,
    MAX_TICKS_PER_MOVE,
    check_ticks_per_move,
    move_ticks,
)


def test_without_speeds_every_move_takes_ticks_per_move_and_one_is_lock_step():
    assert move_ticks(1, 4).tolist() == [1, 1, 1, 1]
    assert move_ticks(LORR_TICKS_PER_MOVE, 3).tolist() == [10, 10, 10]
    assert move_ticks(7, 0).shape == (0,)
    assert move_ticks(3, 2).dtype == np.int64


def test_a_faster_robot_takes_fewer_ticks_rounded_up_and_a_slower_one_more():
    ticks = move_ticks(10, 6, [1, 2, 3, 0.5, 0.3, 100])
    assert ticks.tolist() == [10, 5, 4, 20, 34, 1]


def test_one_speed_applies_to_every_robot():
    assert move_ticks(10, 3, 2.5).tolist() == [4, 4, 4]
    assert move_ticks(4, 2, np.int32(2)).tolist() == [2, 2]


def test_decimal_speeds_give_the_ticks_they_mean_despite_binary_floats():
    assert 21 / 0.7 > 30  # in floats: 30.000000000000004
    assert move_ticks(21, 3, [0.7, 1.4, 0.35]).tolist() == [30, 15, 60]
    assert move_ticks(3, 3, [0.3, 1 / 3, 0.1]).tolist() == [10, 9, 30]
    assert move_ticks(10, 2, [0.7, 1.1]).tolist() == [15, 10]  # 14.29 and 9.09, rounded up


@given(
    ticks=st.integers(1, MAX_TICKS_PER_MOVE),
    numerator=st.integers(1, 1000),
    denominator=st.integers(1, 1000),
)
def test_the_ticks_are_the_exact_ceiling_of_ticks_over_a_decimal_speed(
    ticks, numerator, denominator
):
    speed = Fraction(numerator, denominator)
    exact = max(1, math.ceil(ticks / speed))
    if exact > MAX_TICKS_PER_MOVE:
        with pytest.raises(ValueError, match="speed of robot 0"):
            move_ticks(ticks, 1, [float(speed)])
        return
    # The exact quotient is an integer or at least 1/1000 above one: far beyond the
    # 1e-9 slack that absorbs the float division's error.
    assert move_ticks(ticks, 1, [float(speed)]).tolist() == [exact]


@pytest.mark.parametrize(
    ("value", "error", "words"),
    [
        (True, TypeError, "ticks_per_move must be an integer, got True"),
        (np.bool_(True), TypeError, "ticks_per_move must be an integer"),
        (3.0, TypeError, "ticks_per_move must be an integer, got 3.0"),
        (float("nan"), TypeError, "ticks_per_move must be an integer, got nan"),
        ("3", TypeError, "ticks_per_move must be an integer, got '3'"),
        (np.timedelta64(3), TypeError, "ticks_per_move must be an integer"),
        (0, ValueError, "ticks_per_move must be 1 to 10,000, got 0"),
        (-2, ValueError, "ticks_per_move must be 1 to 10,000, got -2"),
        (10**30, ValueError, "ticks_per_move must be 1 to 10,000, got 1,000,000,000"),
    ],
)
def test_a_bad_ticks_per_move_is_one_line_naming_it(value, error, words):
    with pytest.raises(error) as caught:
        move_ticks(value, 3)
    assert str(caught.value).startswith(words)
    assert "\n" not in str(caught.value)
    with pytest.raises(error):
        check_ticks_per_move(value)


def test_check_ticks_per_move_names_the_argument_it_is_given():
    assert check_ticks_per_move(np.int64(3)) == 3
    assert type(check_ticks_per_move(np.int64(3))) is int
    with pytest.raises(ValueError, match=r"^agentCounter must be 1 to 10,000, got 0$"):
        check_ticks_per_move(0, "agentCounter")


@pytest.mark.parametrize(
    ("n_robots", "error", "words"),
    [
        (True, TypeError, "n_robots must be an integer"),
        (2.0, TypeError, "n_robots must be an integer"),
        (-1, ValueError, "n_robots must be 0 to 1,000,000, got -1"),
        (10**12, ValueError, "n_robots must be 0 to 1,000,000"),
    ],
)
def test_a_bad_robot_count_is_refused_naming_it(n_robots, error, words):
    with pytest.raises(error, match=f"^{words}"):
        move_ticks(3, n_robots)


@pytest.mark.parametrize(
    ("speed", "error", "words"),
    [
        (True, TypeError, "speed must be real numbers, got True"),
        ([True, False], TypeError, "speed must be real numbers, got an array of bool"),
        ("fast", TypeError, "speed must be real numbers, got 'fast'"),
        ([1 + 1j, 1], TypeError, "speed must be real numbers, got an array of complex128"),
        ([[1, 2], [3]], TypeError, "speed must be real numbers"),
        ([1, None], TypeError, "speed must be real numbers, got an array of object"),
        (
            [1, 2, 3],
            ValueError,
            r"speed must be one number or one a robot \(2,\), got shape \(3,\)",
        ),
        ([[1, 2]], ValueError, "speed must be one number or one a robot"),
        ([1, 0], ValueError, "speed must be finite and above 0, got 0.0 for robot 1"),
        ([-1, 1], ValueError, "speed must be finite and above 0, got -1.0 for robot 0"),
        ([1, float("nan")], ValueError, "speed must be finite and above 0, got nan for robot 1"),
        ([float("inf"), 1], ValueError, "speed must be finite and above 0, got inf for robot 0"),
        ([1, 1e-3], None, None),  # exactly 10,000 ticks: the most there may be
        ([1, 9.99e-4], ValueError, "speed of robot 1 .0.000999. makes a move take more than"),
        ([1e-320, 1], ValueError, "speed of robot 0"),  # 10 / 1e-320 overflows to inf
    ],
)
def test_a_bad_speed_is_one_line_naming_it_and_the_robot(speed, error, words):
    if error is None:
        assert move_ticks(10, 2, speed).tolist() == [10, MAX_TICKS_PER_MOVE]
        return
    with pytest.raises(error) as caught:
        move_ticks(10, 2, speed)
    assert caught.match(f"^{words}")
    assert "\n" not in str(caught.value)


def test_the_speed_array_given_is_left_as_it_was():
    speed = np.array([1.0, 2.0])
    speed.flags.writeable = False  # a read-only input is fine too
    assert move_ticks(10, 2, speed).tolist() == [10, 5]
    assert speed.tolist() == [1.0, 2.0]
