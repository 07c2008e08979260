"""The physics twin's native vector environment: many warehouse floors stepped at once,
every robot a body in one pymunk space.

``gym.make_vec("warehouse-robot-phys-v0", num_envs=N)`` returns
:class:`WarehousePhysicsVectorEnv` (the ``vector_entry_point`` of the physics twin's
ids): the grid twin's vector environment
(:class:`~warehouse_phys.envs.vector.WarehouseGridVectorEnv`) with its moves driven
through :class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld`. Its
specification is its class docstring.
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from warehouse_phys.envs.base import checked_record_path, recording_world
from warehouse_phys.envs.checks import checked_count
from warehouse_phys.envs.vector import WarehouseGridVectorEnv
from warehouse_phys.physics import PhysicsConfig, check_controller, physics_config_from
from warehouse_phys.physics.batched import BatchedPhysicsWorld

__all__ = ["MAX_PHYSICS_ENVS", "WarehousePhysicsVectorEnv"]

#: Most sub-environments in one physics vector environment: each floor's walls, robot
#: and controller take about 16 KB, so the largest takes about 1 GB and builds in 11 s.
MAX_PHYSICS_ENVS = 2**16

#: The keywords of the grid twin's constructor; the physics twin's others are physical.
_GRID_KEYWORDS = frozenset(inspect.signature(WarehouseGridVectorEnv).parameters)


class WarehousePhysicsVectorEnv(WarehouseGridVectorEnv):
    """``num_envs`` physics-backed warehouse floors, all robots in one pymunk space.

    ## Description
    Each sub-environment is a :class:`~warehouse_phys.envs.WarehousePhysicsEnv`
    made through ``gym.make`` (with its time limit), and every robot is driven
    by the same controller, through the same two phases, read back and snapped
    the same way (see :mod:`warehouse_phys.physics`). The robots live in one
    :class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld`: one pymunk
    space holding a copy of the floor per sub-environment, far from the others,
    so that one space step advances every robot and chipmunk's fixed cost per
    step is shared. Positions go in and out through pymunk's batched I/O.

    The tests replay every sub-environment's episodes in a single
    ``gym.make("warehouse-robot-phys-v0")``: the same observations, rewards,
    terminations, truncations and ``optimal_steps``, and body positions within
    ``1e-9`` cells of the single environment's at every physics step.
    Sub-environment 0's floor sits where the single environment's does and its
    robot follows it bit for bit; the other floors are offset, which rounds
    their coordinates to the offset's precision (differences near ``1e-14``
    cells; see :mod:`warehouse_phys.physics.batched`).

    ## Action Space
    As :class:`WarehouseGridVectorEnv`: ``MultiDiscrete([4] * num_envs)``,
    LEFT=0, DOWN=1, RIGHT=2, UP=3, checked the same way.

    ## Observation Space
    As :class:`WarehouseGridVectorEnv`: ``(num_envs, 4)`` int64 rows
    ``[robot_row, robot_col, target_row, target_col]``, the robot's cell read
    from its body, or their one-hot rows with ``observation="onehot"``.

    ## Starting State
    Every robot at rest on the start cell; packages drawn as in
    :class:`WarehouseGridVectorEnv` (the same seed gives the same packages in
    both). A sub-environment that restarts (after its episode ended, or through
    ``reset_mask``) gets its robot renewed (see
    :func:`~warehouse_phys.physics.renew_robot`): no contact or solver state is
    left over, and its episode replays bit for bit whatever came before it.

    ## Rewards
    As :class:`WarehouseGridVectorEnv`: 1.0 on the step a robot reaches its
    package, else 0.0, less ``step_penalty`` and ``bump_penalty``.

    ## Episode End
    As :class:`WarehouseGridVectorEnv`: termination on the package, truncation at
    ``max_episode_steps``, next-step autoreset, ``reset(options={"reset_mask": mask})``.

    ``infos`` holds ``"optimal_steps"`` and ``"snap_error"`` (float64, the distance
    between each body and its cell's centre before the snap [cells], always
    below ``SNAP_ERROR_BOUND``; 0.0 on a sub-environment's first step of an
    episode), each with its ``_`` mask.

    ## Arguments
    - ``num_envs`` (int, default 1): how many floors, 1 to :data:`MAX_PHYSICS_ENVS`
      (65,536; each floor takes about 16 KB).
    - ``grid_rows``, ``grid_cols``, ``layout``, ``max_episode_steps``, ``cell_px``
      and the keyword-only ``observation``, ``step_penalty``, ``bump_penalty``:
      as in :class:`WarehouseGridVectorEnv`.
    - ``render_mode`` (``None``, ``"rgb_array"`` or ``"ansi"``): ``render()``
      returns one frame per sub-environment, after the snap.
    - ``record_path`` (bool or ``None``): whether each step records every body's
      position after each physics step, for :attr:`last_move_paths`; by default
      when ``render_mode`` is ``"rgb_array"``.
    - The physical parameters of :class:`~warehouse_phys.envs.WarehousePhysicsEnv`,
      keyword-only (``cell_size``, ``robot_radius``, ``robot_mass``,
      ``floor_damping``, ``max_speed``, ``max_force``, ``gain``, ``dt``,
      ``move_duration``, ``settle_time``), checked the same way.

    ```python
    import gymnasium as gym
    import numpy as np
    import warehouse_phys

    envs = gym.make_vec("warehouse-robot-phys-v0", num_envs=256)
    obs, infos = envs.reset(seed=0)
    obs, rewards, terminations, truncations, infos = envs.step(np.full(256, 2))
    infos["snap_error"].max() < warehouse_phys.SNAP_ERROR_BOUND  # True
    ```

    One robot is faster in ``gym.make``: a step of this environment has a
    fixed cost of array work that pays off from about 16 robots on.

    ## Version History
    - v0: first version.
    """

    def __init__(
        self, num_envs: int = 1, *args: Any, record_path: bool | None = None, **keywords: Any
    ) -> None:
        checked_count("num_envs", num_envs, MAX_PHYSICS_ENVS)
        physics = {
            name: keywords.pop(name) for name in list(keywords) if name not in _GRID_KEYWORDS
        }
        # The floors, time limit, rendering, observation and penalties: as in the grid twin.
        super().__init__(num_envs, *args, **keywords)
        #: The physical parameters, checked here as the single environment checks them.
        self.physics: PhysicsConfig = physics_config_from(physics)
        check_controller(self.physics)
        self.record_path = checked_record_path(record_path, self.render_mode)
        #: The world of every sub-environment's robot, built by the first reset.
        self.world: BatchedPhysicsWorld | None = None
        self._snap_error = np.zeros(self.num_envs)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start new episodes on every floor, or on those ``options["reset_mask"]`` marks,
        each on a robot as newly built (the world is built by the first reset and
        restarted after, :meth:`BatchedPhysicsWorld.restart`)."""
        return super().reset(seed=seed, options=options)

    @property
    def last_move_paths(self) -> np.ndarray:
        """Every body's position after each physics step of the last step, before the snap.

        A fresh float64 array of shape ``(num_envs, steps_per_move, 2)`` of
        ``(row, col)`` in cell units (cell centres are whole numbers); a
        sub-environment that restarted holds its start cell throughout.

        Raises:
            gymnasium.error.ResetNeeded: before the first reset.
            RuntimeError: if the environment does not record paths (see ``record_path``).
        """
        return recording_world(self.world, self.record_path, "last_move_paths").last_paths

    # ------------------------------------------------------------------ hooks
    def _move_robots(self, actions: np.ndarray) -> np.ndarray:
        cells, self._snap_error = self.world.move_by(actions)
        return (cells[:, 0] * self.grid_cols + cells[:, 1]) * 4

    def _restart(self, floors: np.ndarray, pos4: np.ndarray) -> None:
        super()._restart(floors, pos4)
        starts = np.tile(np.array(self.grid.start, dtype=np.int64), (len(floors), 1))
        if self.world is None:
            self.world = BatchedPhysicsWorld(
                self.grid, self.physics, starts, record_path=self.record_path
            )
        else:
            self.world.restart(floors, starts)
        self._snap_error = self._snap_error.copy()  # the last step's infos keep theirs
        self._snap_error[floors] = 0.0

    def _infos(self) -> dict[str, Any]:
        infos = super()._infos()
        infos["snap_error"] = self._snap_error.copy()
        infos["_snap_error"] = np.ones(self.num_envs, dtype=bool)
        return infos
