"""League of Robot Runners problems as PettingZoo fleets.

``warehouse_phys.envs.lorr.fleet("MR23-I-10.json", moves="rotate")`` is the fleet of an
instance: its floor, its robots on their starts (facing east) and its task list handed
out as the competition does (:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv` with
``instance=``). ``parallel_env`` and ``env`` are PettingZoo's two forms of it.
``async_fleet(path)`` runs the instance on ticks, with its ``agentCounter`` and
``delayConfig`` (League of Robot Runners 2026), a tick a step. An instance's fleet
driven by PIBT::

    from warehouse_phys.envs import lorr
    from warehouse_phys.rl.fleet_planners import pibt_policy

    env = lorr.fleet("../shared/lorr/2023-main-warehouse/MR23-I-10.json", moves="rotate")
    observations, infos = env.reset(seed=0)
    policy = pibt_policy(seed=0)
    for _ in range(100):
        observations, rewards, _, _, infos = env.step(policy(env, observations, infos))
    env.errands.errands_done, env.errands.tasks_done  # as the competition counts them
"""

from __future__ import annotations

import os
from typing import Any

from pettingzoo import AECEnv

from warehouse_phys.envs import fleet as _fleet
from warehouse_phys.envs.async_fleet import AsyncFleetEnv
from warehouse_phys.envs.fleet import WarehouseFleetEnv
from warehouse_phys.lorr.instances import LorrInstance


def fleet(
    instance: LorrInstance | str | os.PathLike[str], *, moves: str = "rotate", **kwargs: Any
) -> WarehouseFleetEnv:
    """The fleet of ``instance`` (a :class:`~warehouse_phys.lorr.instances.LorrInstance` or
    the path of its JSON file) as a PettingZoo ``ParallelEnv``; ``moves`` defaults to the
    competition's turning robots, and ``kwargs`` are the fleet's (``physics``,
    ``scheduler``, ``record_errands``, ``observation``, ``max_cycles``, ...).

    Raises:
        ValueError: for a bad instance file (one line naming the file and line) or a
            keyword the instance decides (``layout``, ``num_robots``, ...).
    """
    return WarehouseFleetEnv(instance=instance, moves=moves, **kwargs)


def async_fleet(
    instance: LorrInstance | str | os.PathLike[str], *, moves: str = "rotate", **kwargs: Any
) -> AsyncFleetEnv:
    """The fleet of ``instance`` on ticks, as LoRR 2026 runs it: a move or turn takes the
    instance's ``agentCounter`` ticks, its ``delayConfig`` delays the robots, and the
    executor says GO or STOP to each robot each tick
    (:class:`~warehouse_phys.envs.async_fleet.AsyncFleetEnv`; ``kwargs`` are its:
    ``physics``, ``ticks_per_move``, ``delays``, ``max_cycles``, ...)."""
    return AsyncFleetEnv(instance=instance, moves=moves, **kwargs)


def parallel_env(**kwargs: Any) -> WarehouseFleetEnv:
    """:func:`fleet` with every argument by keyword (PettingZoo's module convention)."""
    return fleet(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The instance fleet as a PettingZoo AEC environment."""
    return _fleet.env(moves=kwargs.pop("moves", "rotate"), **kwargs)
