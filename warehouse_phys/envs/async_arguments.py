"""The asynchronous fleet's own arguments, checked: its GO/STOP actions, its executor's
``min_gap`` and its delays, and the physics twin's tick and gap.

Each check returns what :class:`~warehouse_phys.envs.async_fleet.AsyncFleetEnv` keeps, or
raises a one-line ``TypeError`` (the wrong kind of value) or ``ValueError`` (out of
range) that names the argument (and the robot, for an action).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.envs.checks import is_integer_scalar, number_text
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.tick_controller import required_min_gap
from warehouse_phys.physics.ticking import default_tick_steps

__all__ = [
    "ACTION_NAMES",
    "GO",
    "STOP",
    "checked_async_action",
    "checked_gap",
    "delay_config",
    "gap_and_steps",
]

#: The actions: hold the robot this tick, or let the executor drive it.
STOP, GO = 0, 1
#: The actions in words, for messages.
ACTION_NAMES = "0 (STOP) or 1 (GO)"


def checked_async_action(agent: str, action: object) -> int:
    """``action`` as STOP or GO, or an error naming ``agent``: a ``TypeError`` for anything
    but one integer (bools, floats, numpy's durations, which numpy counts as integers), a
    ``ValueError`` for another integer or a masked value."""
    if np.ma.is_masked(action):
        raise ValueError(f"{agent}'s action is masked: it has no value")
    if not is_integer_scalar(action):
        raise TypeError(f"{agent}'s action must be {ACTION_NAMES}, got {action!r} "
                        f"({type(action).__name__})")  # fmt: skip
    if int(action) not in (STOP, GO):
        raise ValueError(f"{agent}'s action must be {ACTION_NAMES}, got {number_text(action)}")
    return int(action)


def checked_gap(min_gap: object) -> float | None:
    """``min_gap`` as a float in (0, 1] cells (``None``, the default, stays ``None``), or a
    ``TypeError``/``ValueError`` naming it."""
    if min_gap is None:
        return None
    real = isinstance(min_gap, (int, float, np.integer, np.floating))
    if isinstance(min_gap, (bool, np.bool_, np.timedelta64)) or not real:
        raise TypeError(f"min_gap must be a real number of cells, got {min_gap!r} "
                        f"({type(min_gap).__name__})")  # fmt: skip
    try:
        gap = float(min_gap)
    except OverflowError:  # an integer beyond floats: beyond a cell too
        gap = float("inf")
    if not 0 < gap <= 1:  # NaN too
        raise ValueError(f"min_gap must be in (0, 1] cells, got {number_text(min_gap)}")
    return gap


def delay_config(delays: DelayConfig | dict[str, Any] | None) -> DelayConfig | None:
    """``delays`` as a :class:`~warehouse_phys.execution.delays.DelayConfig` (from its JSON
    dict) or ``None``, or a ``TypeError``."""
    if delays is None or isinstance(delays, DelayConfig):
        return delays
    if isinstance(delays, dict):
        return DelayConfig.from_json(delays)
    raise TypeError(f"delays must be a DelayConfig, its JSON dict or None, got {delays!r}")


def gap_and_steps(
    physics: PhysicsConfig | None,
    turning: bool,
    min_gap: float | None,
    tick_steps: int | None,
    needed: np.ndarray,
) -> tuple[int | None, float]:
    """The physics steps of a tick (``None`` in the grid twin) and the executor's
    ``min_gap`` [cells]: the given one, or the executor's default, or with physics what
    the bodies need (``required_min_gap``, for the fastest robots' ``needed`` ticks a
    move); a given one below that is refused."""
    if physics is None:
        if tick_steps is not None:
            raise ValueError("tick_steps is for the physics twin (physics=True)")
        return None, DEFAULT_MIN_GAP if min_gap is None else min_gap
    fastest = int(needed.min())
    steps = default_tick_steps(physics, fastest) if tick_steps is None else tick_steps
    needs = required_min_gap(physics, fastest, steps, turning=turning)
    if min_gap is not None and min_gap < needs:
        raise ValueError(f"min_gap {min_gap} cells is less than the {needs:.3g} cells "
                         "these bodies need (required_min_gap)")  # fmt: skip
    return steps, needs if min_gap is None else min_gap
