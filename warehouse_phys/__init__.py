"""warehouse_phys: reinforcement learning for a robot on a warehouse floor.

Importing the package registers its Gymnasium environments:

- ``warehouse-robot-v0``: the pure-grid environment (:class:`WarehouseGridEnv`);
- ``warehouse-robot-phys-v0``: the physics-backed twin (:class:`WarehousePhysicsEnv`);
- ``warehouse-robot-<preset>-v0`` and ``warehouse-robot-phys-<preset>-v0`` for
  each warehouse layout of :data:`warehouse_phys.layouts.PRESETS` (``aisles``,
  ``depot``, ``maze``), with time limits that suit their sizes.

``gym.make("warehouse_phys:warehouse-robot-phys-v0")`` imports the package itself.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from warehouse_phys.envs import WarehouseEnvBase, WarehouseGridEnv, WarehousePhysicsEnv
from warehouse_phys.grid import Action, Cell, WarehouseGrid
from warehouse_phys.layouts import PRESETS, preset_ids
from warehouse_phys.physics import SNAP_ERROR_BOUND, PhysicsConfig

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

GRID_ENV_ID = "warehouse-robot-v0"
PHYSICS_ENV_ID = "warehouse-robot-phys-v0"

#: Time limit of the registered ids: a random walk on the default 4 x 5 floor
#: ends within it in 98.6 % of episodes (45 steps on average).
DEFAULT_MAX_EPISODE_STEPS = 200

_GRID_ENTRY_POINT = "warehouse_phys.envs:WarehouseGridEnv"
_PHYSICS_ENTRY_POINT = "warehouse_phys.envs:WarehousePhysicsEnv"

#: ``gym.make_vec`` builds every id natively (see :mod:`warehouse_phys.vector`).
_GRID_VECTOR_ENTRY_POINT = "warehouse_phys.vector:WarehouseGridVectorEnv"
_PHYSICS_VECTOR_ENTRY_POINT = "warehouse_phys.vector:WarehousePhysicsVectorEnv"

_REGISTRATIONS = [
    (GRID_ENV_ID, _GRID_ENTRY_POINT, _GRID_VECTOR_ENTRY_POINT, {}, DEFAULT_MAX_EPISODE_STEPS),
    (
        PHYSICS_ENV_ID,
        _PHYSICS_ENTRY_POINT,
        _PHYSICS_VECTOR_ENTRY_POINT,
        {},
        DEFAULT_MAX_EPISODE_STEPS,
    ),
]
for _preset in PRESETS.values():
    _grid_id, _physics_id = preset_ids(_preset.name)
    _kwargs = {"layout": _preset.name}
    _limit = _preset.max_episode_steps
    _REGISTRATIONS.append((_grid_id, _GRID_ENTRY_POINT, _GRID_VECTOR_ENTRY_POINT, _kwargs, _limit))
    _REGISTRATIONS.append(
        (_physics_id, _PHYSICS_ENTRY_POINT, _PHYSICS_VECTOR_ENTRY_POINT, _kwargs, _limit)
    )

for _env_id, _entry_point, _vector_entry_point, _kwargs, _max_steps in _REGISTRATIONS:
    if _env_id not in registry:  # importing twice (e.g. a reload) must not warn
        register(
            id=_env_id,
            entry_point=_entry_point,
            vector_entry_point=_vector_entry_point,
            kwargs=_kwargs,
            max_episode_steps=_max_steps,
        )
