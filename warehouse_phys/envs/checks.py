"""What the environments refuse, each check naming the bad input in its error: a single
environment's action, penalties, choices among names, integers, and the vector
environments' counts, actions and reset masks; numbers written for error messages.

A check returns the value it accepts (as the type the environment keeps) or raises
``TypeError`` (the wrong kind of value) or ``ValueError`` (a value out of range).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from warehouse_phys.world.grid import Action

#: The actions in value order, so that ``_ACTIONS[i]`` is ``Action(i)`` without an enum lookup.
_ACTIONS: tuple[Action, ...] = tuple(Action)

_ACTION_RANGE = ", ".join(f"{a.name}={a.value}" for a in Action)


#: The exact types of plain integer scalars, which ``np.fromiter(..., np.int64)`` converts
#: one by one (never through float) and refuses with ``OverflowError`` beyond int64.
INTEGER_TYPES = frozenset({int, np.int64, np.int32, np.int16, np.int8, np.uint8,
                           np.uint16, np.uint32, np.uint64})  # fmt: skip


def number_text(value: object) -> str:
    """``value`` for an error message: ``repr``, but an integer beyond 64 bits by its size.

    Python refuses to write an int of more than 4300 digits (``str`` raises), and
    one of 400 digits tells a reader less than its size does.
    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.timedelta64)):
        bits = int(value).bit_length()
        if bits > 64:
            return f"{'a negative' if value < 0 else 'an'} integer of {bits} bits"
    return repr(value)


def checked_choice(name: str, value: object, choices: Sequence[str]) -> str:
    """``value`` if it is one of ``choices``, else a ``ValueError`` (``TypeError`` for a
    non-string) naming ``name`` and the choices."""
    if not isinstance(value, str):
        raise TypeError(
            f"{name} must be one of {list(choices)}, got {value!r} ({type(value).__name__})"
        )
    if value not in choices:
        raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")
    return value


def checked_penalty(name: str, value: object) -> float:
    """``value`` as a float, if it is a finite real number >= 0, else an error naming ``name``.

    Raises:
        TypeError: if ``value`` is not a real number (a bool, a string, ``None``, ...).
        ValueError: if it is negative, infinite, NaN or an integer too large for a float.
    """
    if isinstance(value, (bool, np.bool_, np.timedelta64)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise TypeError(
            f"{name} must be a real number >= 0, got {value!r} ({type(value).__name__})"
        )
    try:
        number = float(value)
    except OverflowError:  # a Python int beyond 1.8e308
        number = math.nan
    if not math.isfinite(number) or number < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {number_text(value)}")
    return number


def checked_penalties(step_penalty: object, bump_penalty: object) -> tuple[float, float]:
    """``step_penalty`` and ``bump_penalty``, each through :func:`checked_penalty`, as floats.

    Raises:
        TypeError, ValueError: as :func:`checked_penalty`, naming the penalty; and
            ``ValueError`` if their sum, what a refused step costs, is infinite.
    """
    step = checked_penalty("step_penalty", step_penalty)
    bump = checked_penalty("bump_penalty", bump_penalty)
    if not math.isfinite(step + bump):  # two finite halves of an infinite reward
        raise ValueError(
            f"step_penalty + bump_penalty must be finite (a bump costs both), "
            f"got {step!r} + {bump!r}"
        )
    return step, bump


def checked_action(action: object) -> Action:
    """The :class:`Action` for ``action``, or a ``TypeError``/``ValueError`` naming it."""
    kind = type(action)
    if (kind is int or kind is np.int64) and 0 <= action < len(_ACTIONS):  # the usual cases
        return _ACTIONS[action]
    if np.ma.is_masked(action):  # np.ma.masked, or a masked array with its value masked
        raise ValueError(
            f"invalid action: a masked value ({type(action).__name__}) is no action; "
            f"expected an integer in 0..3 ({_ACTION_RANGE})"
        )
    if not is_integer_scalar(action):
        raise TypeError(
            f"invalid action {action!r} of type {type(action).__name__}: "
            f"expected an integer in 0..3 ({_ACTION_RANGE})"
        )
    value = int(action)
    if not 0 <= value < len(_ACTIONS):
        shown = number_text(action)
        shown = f"({shown})" if " " in shown else shown  # "an integer of N bits", bracketed
        raise ValueError(f"invalid action {shown}: expected an integer in 0..3 ({_ACTION_RANGE})")
    return _ACTIONS[value]


def is_integer_scalar(value: object) -> bool:
    """Whether ``value`` is one integer: a Python or numpy integer or a 0-d integer array
    (in either byte order), but neither a bool nor a duration."""
    return is_integer(value) or (
        isinstance(value, np.ndarray) and value.shape == () and value.dtype.kind in "iu"
    )


def is_integer(value: object) -> bool:
    """Whether ``value`` is a Python or numpy integer, but neither a bool nor a duration
    (numpy counts ``timedelta64`` as an integer)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.timedelta64))


# ------------------------------------------------------------ the vector environments'
_MUST = "actions must be integers in 0..3 (LEFT=0, DOWN=1, RIGHT=2, UP=3)"


def checked_count(name: str, value: object, maximum: int | None) -> int:
    """``value`` as an int, if it is an integer from 1 to ``maximum`` (``None``: no
    maximum), else a ``TypeError``/``ValueError`` naming ``name``."""
    if isinstance(value, (bool, np.timedelta64)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < 1 or (maximum is not None and value > maximum):
        limit = f"1 to {maximum}" if maximum is not None else "at least 1"
        raise ValueError(f"{name} must be {limit}, got {number_text(value)}")
    return int(value)


def checked_vector_actions(actions: Any, num_envs: int) -> np.ndarray:
    """A vector environment's ``actions``, one per sub-environment, as ``(num_envs,)``
    int64 in 0..3, or a ``TypeError``/``ValueError`` naming the sub-environment (see
    :class:`~warehouse_phys.envs.vector.WarehouseGridVectorEnv`'s Action Space)."""
    if type(actions) is not np.ndarray:
        actions = _actions_array(actions, num_envs)
    if actions.shape != (num_envs,):
        raise ValueError(
            f"actions must have shape ({num_envs},), one per sub-environment, "
            f"got shape {actions.shape}"
        )
    if actions.dtype.kind not in "iu":
        raise TypeError(f"{_MUST}, got dtype {actions.dtype}")
    if not actions.dtype.isnative:  # big-endian on most machines: read as native numbers
        actions = actions.astype(actions.dtype.newbyteorder("="))
    if actions.view(f"u{actions.itemsize}").max() > 3:  # negatives look huge unsigned
        bad = np.flatnonzero((actions < 0) | (actions > 3))
        raise ValueError(
            f"{_MUST}: sub-environment {bad[0]} got {actions[bad[0]]}"
            + (f" (and {len(bad) - 1} more)" if len(bad) > 1 else "")
        )
    # int64 indexes the move table whatever the caller's integers (uint64 + int64
    # would make floats); no copy when they are int64 already.
    return actions.astype(np.int64, copy=False)


def _actions_array(actions: Any, num_envs: int) -> np.ndarray:
    """``actions`` (a list, a masked array, ...) as a plain array, or a one-line error."""
    if isinstance(actions, np.ma.MaskedArray):
        if actions.shape == (num_envs,):  # another shape: the caller's shape error
            _refuse_masked(np.ma.getmaskarray(actions))
        return np.asarray(actions.data)
    if isinstance(actions, (list, tuple)):
        return _list_actions(actions, num_envs)
    try:
        return np.asarray(actions)
    except (TypeError, ValueError) as error:
        raise _no_array(actions, error, num_envs) from None


def _list_actions(items: list | tuple, num_envs: int) -> np.ndarray:
    """A list of actions as int64, converted item by item when they are integer scalars:
    numpy would make float64 of ``[np.int8(2), np.uint64(1)]`` and of ``[2**63]``."""
    if set(map(type, items)) <= INTEGER_TYPES:  # the usual case: one conversion
        try:
            return np.fromiter(items, np.int64, len(items))
        except OverflowError:  # beyond int64, so beyond 0..3: name the first such
            bad = next(i for i, item in enumerate(items) if not -(2**63) <= item < 2**63)
            raise ValueError(
                f"{_MUST}: sub-environment {bad} got {number_text(int(items[bad]))}"
            ) from None
    _refuse_masked(np.array([np.ma.is_masked(item) for item in items], dtype=bool))
    for index, item in enumerate(items):
        if isinstance(item, (bool, np.bool_)):  # numpy would make 1 of True
            raise TypeError(f"{_MUST}: sub-environment {index}'s is a bool, not an integer")
    if all(is_integer_scalar(item) for item in items):  # 0-d arrays, other byte orders
        return _list_actions([int(item) for item in items], num_envs)
    try:
        return np.asarray(items)
    except (TypeError, ValueError) as error:  # a ragged list, say
        raise _no_array(items, error, num_envs) from None


def _refuse_masked(masked: np.ndarray) -> None:
    if masked.any():
        raise ValueError(f"{_MUST}: sub-environment {np.flatnonzero(masked)[0]}'s is masked")


def _no_array(actions: Any, error: Exception, num_envs: int) -> ValueError:
    return ValueError(
        f"actions must be an array of shape ({num_envs},) of integers in 0..3; "
        f"numpy cannot make an array of this {type(actions).__name__}: "
        f"{str(error).splitlines()[0]}"
    )


def checked_reset_mask(options: dict[str, Any] | None, num_envs: int) -> np.ndarray | None:
    """A vector environment's ``options["reset_mask"]`` as a plain boolean array of shape
    ``(num_envs,)`` marking at least one sub-environment, ``None`` for no mask, or a
    ``TypeError``/``ValueError`` saying what is wrong."""
    if options is None:
        return None
    if not isinstance(options, dict):
        raise TypeError(f"reset options must be a dict or None, got {type(options).__name__}")
    unknown = [key for key in options if key != "reset_mask"]
    if unknown:
        raise ValueError(
            f"unknown reset option(s) {', '.join(map(repr, unknown))}; known: ['reset_mask']"
        )
    mask = options.get("reset_mask")
    if mask is None:
        return None
    if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
        raise TypeError(
            f"options['reset_mask'] must be a numpy array of bools, got {type(mask).__name__}"
            + (f" of {mask.dtype}" if isinstance(mask, np.ndarray) else "")
        )
    if mask.shape != (num_envs,):
        raise ValueError(f"options['reset_mask'] must have shape ({num_envs},), got {mask.shape}")
    if np.ma.is_masked(mask):  # a masked entry says neither restart nor keep
        raise ValueError(
            f"options['reset_mask'] has a masked entry (sub-environment "
            f"{np.flatnonzero(np.ma.getmaskarray(mask))[0]}): every entry must be a bool"
        )
    mask = np.array(mask)  # a plain copy, whatever the subclass
    if not mask.any():
        raise ValueError("options['reset_mask'] must mark at least one sub-environment")
    return mask


#: The option PettingZoo's API tests pass to ``reset`` (``{"options": 1}``) to see that an
#: environment takes options: accepted and ignored by the fleets.
PETTINGZOO_PROBE_OPTION = "options"


def checked_reset_options(options: object, known: Sequence[str]) -> dict[str, Any]:
    """A fleet's ``reset(options=...)`` as a dict (``{}`` for ``None``), or a one-line
    ``TypeError`` (not a dict) / ``ValueError`` naming the options it does not know
    (``known``; PettingZoo's probe :data:`PETTINGZOO_PROBE_OPTION` is let through)."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise TypeError(f"reset options must be a dict or None, got {type(options).__name__}")
    unknown = [key for key in options if key not in known and key != PETTINGZOO_PROBE_OPTION]
    if unknown:
        names = ", ".join(repr(key) for key in known) or "none"
        raise ValueError(f"unknown reset option(s) {', '.join(map(repr, unknown))}; known: {names}")
    return options
