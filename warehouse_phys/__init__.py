"""warehouse_phys: reinforcement learning for a robot on a warehouse floor.

Importing the package registers its Gymnasium environments (see
:mod:`warehouse_phys.envs.registration`): ``warehouse-robot-v0`` (the grid twin),
``warehouse-robot-phys-v0`` (the physics twin) and one pair per preset layout.
``gym.make("warehouse_phys:warehouse-robot-phys-v0")`` imports the package itself.

The package is built in floors, each importing only those below it (ARCHITECTURE.md):
:mod:`~warehouse_phys.files`, :mod:`~warehouse_phys.world`, :mod:`~warehouse_phys.planners`,
:mod:`~warehouse_phys.execution`, :mod:`~warehouse_phys.lorr`, :mod:`~warehouse_phys.physics`,
:mod:`~warehouse_phys.drawing`, :mod:`~warehouse_phys.envs`, :mod:`~warehouse_phys.rl`,
:mod:`~warehouse_phys.viz`, :mod:`~warehouse_phys.apps`.
The modules of the earlier flat layout still import under their old names
(``warehouse_phys.grid``, ``warehouse_phys.fleet``, ...; see ``warehouse_phys._moved``).
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# A command (python -m warehouse_phys.<app>) imports this first: Ctrl-C here is one line.
with command_interrupts():
    from warehouse_phys import _moved
    from warehouse_phys.envs.base import WarehouseEnvBase
    from warehouse_phys.envs.registration import (
        DEFAULT_MAX_EPISODE_STEPS,
        GRID_ENV_ID,
        PHYSICS_ENV_ID,
        register_environments,
    )
    from warehouse_phys.envs.single import WarehouseGridEnv, WarehousePhysicsEnv
    from warehouse_phys.physics.config import SNAP_ERROR_BOUND, PhysicsConfig
    from warehouse_phys.world.grid import Action, Cell, WarehouseGrid
    from warehouse_phys.world.layouts import PRESETS, preset_ids

__version__ = "0.1.0"

__all__ = [
    "DEFAULT_MAX_EPISODE_STEPS",
    "GRID_ENV_ID",
    "PHYSICS_ENV_ID",
    "PRESETS",
    "SNAP_ERROR_BOUND",
    "Action",
    "Cell",
    "PhysicsConfig",
    "WarehouseEnvBase",
    "WarehouseGrid",
    "WarehouseGridEnv",
    "WarehousePhysicsEnv",
    "__version__",
    "preset_ids",
]

_moved.install()
register_environments()
