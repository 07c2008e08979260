"""The environments floor: Gymnasium and PettingZoo glue over the rules and the physics.

- :mod:`~warehouse_phys.envs.single`: the single robot, grid twin and physics twin;
- :mod:`~warehouse_phys.envs.vector`: their native vector environments;
- :mod:`~warehouse_phys.envs.fleet`: the PettingZoo fleet;
- :mod:`~warehouse_phys.envs.base`: what they share;
- :mod:`~warehouse_phys.envs.registration`: the Gymnasium ids.

The single environments' names are importable from here, as they were from the
single module this package replaces; the fleet and vector modules load on demand.
"""

from __future__ import annotations

from warehouse_phys.envs.base import (
    OBSERVATION_KINDS,
    RenderModes,
    WarehouseEnvBase,
    checked_record_path,
    draw_offscreen_without_display,
    observation_space,
    onehot,
    recording_world,
    status_line,
)
from warehouse_phys.envs.checks import checked_choice, checked_penalty
from warehouse_phys.envs.single import (
    WarehouseGridEnv,
    WarehousePhysicsEnv,
)

__all__ = [
    "OBSERVATION_KINDS",
    "RenderModes",
    "WarehouseEnvBase",
    "WarehouseGridEnv",
    "WarehousePhysicsEnv",
    "checked_choice",
    "checked_penalty",
    "checked_record_path",
    "draw_offscreen_without_display",
    "observation_space",
    "onehot",
    "recording_world",
    "status_line",
]
