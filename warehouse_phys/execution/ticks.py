"""Time in ticks: how many ticks one move of each robot takes.

League of Robot Runners (LoRR) 2026 runs a fleet on a fast clock of *ticks*: a
forward move or a quarter turn takes ``agentCounter`` ticks (10 when an instance does
not say), the executor says GO or STOP to every robot every tick, and random delays
(:mod:`warehouse_phys.execution.delays`) are drawn a tick at a time. This module owns the
first of these: the number of ticks each robot's move takes.

The rule, for ``ticks_per_move`` ``T`` (an integer, 1 to :data:`MAX_TICKS_PER_MOVE`)
and robot ``i``'s speed factor ``s_i`` (a finite real > 0, 1 if none is given):

- robot ``i``'s every move (a forward move or a turn) takes
  ``k_i = ceil(T / s_i)`` ticks, at least 1: a robot twice as fast (``s_i = 2``)
  takes half the ticks, rounded up; one half as fast (``s_i = 0.5``) twice the
  ticks; ``s_i >= T`` gives one tick a move, the fastest there is;
- rounded *up*, so a robot is never planned to arrive sooner than its speed allows
  (the physics twin can always finish a move in its ticks);
- a quotient ``T / s_i`` less than one part in 10^9 above an integer counts as that
  integer, so speeds written in decimal give the ticks they mean despite binary
  floating point (``21 / 0.7`` is ``30.000000000000004`` in floats: 30 ticks, not 31);
- ``k_i`` must not exceed :data:`MAX_TICKS_PER_MOVE` (a speed so small is refused).

LoRR gives every robot the same ``agentCounter``; speed factors are this package's
extension for heterogeneous fleets (all 1 is LoRR's model).

``T = 1`` with no speeds is today's lock step: every move takes one tick. In LoRR a
move's counter advances one tick each tick its robot is told GO and is not delayed,
and is held, not reset, on any other tick; the move is done on its ``k_i``-th such
tick. The executor (:mod:`warehouse_phys.execution.executor`) applies that rule to the
arrays :func:`move_ticks` gives. Like :mod:`warehouse_phys.world.grid`, this module
imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import numbers

import numpy as np
from numpy.typing import ArrayLike

#: Ticks a move takes in LoRR 2026 when an instance names no ``agentCounter``.
LORR_TICKS_PER_MOVE = 10
#: Most ticks one move may take, whatever a robot's speed (the instance reader reads
#: ``agentCounter`` up to the same bound).
MAX_TICKS_PER_MOVE = 10_000
#: Most robots a tick array may hold (as many as an instance may have).
MAX_ROBOTS = 1_000_000
#: Relative slack below which ``T / s`` above an integer rounds down to it.
_ROUNDING_SLACK = 1e-9


def check_whole(name: str, value: object, minimum: int, maximum: int) -> int:
    """``value`` as an ``int`` in ``[minimum, maximum]``, or one error line naming ``name``.

    Raises:
        TypeError: for anything but an integer (a bool, a float, even ``2.0``, a string).
        ValueError: for an integer outside the bounds, with the bounds.
    """
    if isinstance(value, (bool, np.bool_, np.timedelta64)) or not isinstance(
        value, numbers.Integral
    ):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if not minimum <= value <= maximum:
        digits = len(str(abs(int(value)))) if int(value).bit_length() < 14_000 else None
        shown = f"{int(value):,}" if digits is not None and digits <= 40 else (
            f"an integer of {digits or 'over 4,000'} digits")  # fmt: skip
        raise ValueError(f"{name} must be {minimum:,} to {maximum:,}, got {shown}")
    return int(value)


def check_ticks_per_move(value: object, name: str = "ticks_per_move") -> int:
    """``value`` as the ticks a move takes: an integer from 1 to :data:`MAX_TICKS_PER_MOVE`.

    Raises:
        TypeError, ValueError: one line naming ``name``, as :func:`check_whole`.
    """
    return check_whole(name, value, 1, MAX_TICKS_PER_MOVE)


def move_ticks(ticks_per_move: int, n_robots: int, speed: ArrayLike | None = None) -> np.ndarray:
    """The ticks each robot's move takes: ``ceil(ticks_per_move / speed)`` as in the module
    docstring; a fresh ``(n_robots,)`` ``int64`` array, every entry 1 to
    :data:`MAX_TICKS_PER_MOVE`.

    ``speed`` is ``None`` (every robot 1), one number for every robot, or one number a
    robot (shape ``(n_robots,)``).

    Raises:
        TypeError: a non-integer ``ticks_per_move`` or ``n_robots``, or a ``speed`` that is
            not real numbers (bools, strings, complex numbers), naming the argument.
        ValueError: ``ticks_per_move`` or ``n_robots`` out of bounds, ``speed`` of the
            wrong shape, not finite or not above 0, or so small that a move would take
            more than :data:`MAX_TICKS_PER_MOVE` ticks (naming the first such robot).
    """
    ticks = check_ticks_per_move(ticks_per_move)
    n = check_whole("n_robots", n_robots, 0, MAX_ROBOTS)
    if speed is None:
        return np.full(n, ticks, dtype=np.int64)
    factors = _checked_speed(speed, n)
    with np.errstate(over="ignore"):  # inf for tiny speeds: refused below
        quotient = ticks / factors
    counts = np.maximum(np.ceil(quotient * (1.0 - _ROUNDING_SLACK)), 1.0)
    too_slow = np.flatnonzero(counts > MAX_TICKS_PER_MOVE)
    if len(too_slow):
        robot = int(too_slow[0])
        raise ValueError(
            f"speed of robot {robot} ({float(factors[robot])!r}) makes a move take more than "
            f"{MAX_TICKS_PER_MOVE:,} ticks at ticks_per_move {ticks}"
        )
    return counts.astype(np.int64)


def _checked_speed(speed: ArrayLike, n: int) -> np.ndarray:
    """``speed`` as a ``(n,)`` float array of finite factors above 0."""
    if isinstance(speed, (bool, np.bool_, str, bytes)):
        raise TypeError(f"speed must be real numbers, got {speed!r} ({type(speed).__name__})")
    try:
        array = np.asarray(speed)
    except (TypeError, ValueError) as error:  # ragged nests of lists
        raise TypeError(f"speed must be real numbers, got {speed!r} ({error})") from None
    if array.dtype.kind not in "iuf":  # bools, strings, objects, complex numbers
        raise TypeError(f"speed must be real numbers, got an array of {array.dtype}")
    if array.ndim == 0:
        array = np.full(n, array, dtype=np.float64)
    if array.shape != (n,):
        raise ValueError(f"speed must be one number or one a robot {(n,)}, got shape {array.shape}")
    array = array.astype(np.float64)
    bad = np.flatnonzero(~(np.isfinite(array) & (array > 0)))
    if len(bad):
        robot = int(bad[0])
        raise ValueError(
            f"speed must be finite and above 0, got {float(array[robot])!r} for robot {robot}"
        )
    return array
