"""A fleet's observations, actions, rewards and infos as arrays, beside PettingZoo's dicts.

PettingZoo's parallel API hands a fleet one dict of actions a step and takes back four
dicts of ``num_robots`` entries (and an info dict per robot). At 10,000 robots building
and reading them costs more than the planner and the executor together; a caller that
drives the whole fleet does not need them. Both fleets
(:class:`~warehouse_phys.envs.async_fleet.AsyncFleetEnv` and
:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`) therefore offer, beside
``reset``/``step``:

- ``reset_arrays(seed=None, options=None)`` -> ``(observations, infos)``;
- ``step_arrays(actions)`` -> :class:`ArrayStep`,

with row ``i`` of every array robot ``i`` (``possible_agents[i]``): ``observations``
``(N, K)``, the rows the dicts hold; ``actions``, ``rewards``, ``terminations``,
``truncations`` ``(N,)``; ``infos`` a dict of ``(N,)`` arrays under the keys each robot's
info dict has. They run the same step: a run through the arrays and a run through the
dicts with the same actions give the same numbers (the tests prove it), and the dicts stay
the default (PettingZoo's test suites run on them).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from warehouse_phys.envs.checks import INTEGER_TYPES, is_integer_scalar, number_text

__all__ = ["ArrayStep", "action_array", "agent_dicts", "info_dicts", "step_dicts"]


class ArrayStep(NamedTuple):
    """One step of a fleet in array form (see the module): row ``i`` is robot ``i``."""

    #: ``(N, K)`` every robot's observation.
    observations: np.ndarray
    #: ``(N,)`` float64.
    rewards: np.ndarray
    #: ``(N,)`` bool.
    terminations: np.ndarray
    #: ``(N,)`` bool.
    truncations: np.ndarray
    #: Each info key's ``(N,)`` array.
    infos: dict[str, np.ndarray]


def action_array(actions: Any, num_robots: int, count: int, names: str) -> np.ndarray:
    """``actions``, one a robot in robot order, as ``(num_robots,)`` int64 in
    ``0..count - 1``, or a one-line ``TypeError``/``ValueError`` naming the first robot at
    fault (``names`` says what the actions are, for the message: ``"0 (STOP) or 1 (GO)"``).

    Takes a numpy integer array or a list or tuple of integers (Python or numpy, or 0-d
    integer arrays); refuses bools, floats, durations, masked entries and other shapes.
    """
    if isinstance(actions, np.ma.MaskedArray):
        masked = np.flatnonzero(np.ma.getmaskarray(actions))
        if len(masked):
            raise ValueError(f"actions: robot_{masked[0]}'s action is masked")
        actions = np.asarray(actions.data)
    elif isinstance(actions, (list, tuple)):
        actions = _listed(actions, names)
    elif not isinstance(actions, np.ndarray):
        raise TypeError(f"actions must be an array of {num_robots} integers, "
                        f"got {type(actions).__name__}")  # fmt: skip
    if actions.shape != (num_robots,):
        raise ValueError(f"actions must have shape ({num_robots},), one a robot, "
                         f"got shape {actions.shape}")  # fmt: skip
    if actions.dtype.kind not in "iu":
        raise TypeError(f"actions must be integers {names}, got dtype {actions.dtype}")
    values = actions.astype(np.int64, copy=False) if actions.dtype.kind == "i" else actions
    bad = np.flatnonzero((values < 0) | (values >= count))
    if len(bad):
        raise ValueError(f"actions must be {names}: robot_{bad[0]} got {values[bad[0]]}")
    return values.astype(np.int64, copy=False)


def _listed(items: list | tuple, names: str) -> np.ndarray:
    """A list of actions as int64, item by item (numpy would make floats of mixed kinds)."""
    if set(map(type, items)) <= INTEGER_TYPES:
        try:
            return np.fromiter(items, np.int64, len(items))
        except OverflowError:
            bad = next(i for i, item in enumerate(items) if not -(2**63) <= item < 2**63)
            raise ValueError(
                f"actions must be {names}: robot_{bad} got {number_text(int(items[bad]))}"
            ) from None
    for index, item in enumerate(items):
        if np.ma.is_masked(item):
            raise ValueError(f"actions: robot_{index}'s action is masked")
        if not is_integer_scalar(item):
            raise TypeError(f"actions must be integers {names}: robot_{index} got {item!r}")
    return _listed([int(item) for item in items], names)


def step_dicts(agents: list[str], step: ArrayStep) -> tuple[dict, dict, dict, dict, dict]:
    """PettingZoo's five dicts of a step of every robot, ``agents`` (robot order)."""
    return (
        agent_dicts(agents, step.observations),
        agent_dicts(agents, step.rewards.tolist()),
        agent_dicts(agents, step.terminations.tolist()),
        agent_dicts(agents, step.truncations.tolist()),
        info_dicts(agents, step.infos),
    )


def agent_dicts(agents: list[str], rows: np.ndarray | list[Any]) -> dict[str, Any]:
    """``{agent: row}`` for the agents and their rows, in order."""
    return dict(zip(agents, rows, strict=True))


def info_dicts(agents: list[str], columns: dict[str, np.ndarray]) -> dict[str, dict[str, Any]]:
    """Each agent's info dict from the info columns (Python numbers, in key order)."""
    lists = {key: value.tolist() for key, value in columns.items()}
    keys = list(lists)
    rows = zip(agents, zip(*(lists[key] for key in keys), strict=True), strict=True)
    return {agent: dict(zip(keys, row, strict=True)) for agent, row in rows}
