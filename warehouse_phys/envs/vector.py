"""Native vector environments: many warehouse floors stepped at once, as arrays.

``gym.make_vec("warehouse-robot-v0", num_envs=N)`` returns
:class:`WarehouseGridVectorEnv` (the ``vector_entry_point`` of the grid twin's
ids), which steps every floor with a handful of array operations instead of a
Python loop over single environments. ``gym.make_vec("warehouse-robot-phys-v0",
num_envs=N)`` returns
:class:`~warehouse_phys.envs.vector_physics.WarehousePhysicsVectorEnv`, the same
semantics with every robot a body in one pymunk space (a subclass of the grid twin,
in its own module; its names still import from here).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer
from warehouse_phys.drawing.text_frames import ansi_frame
from warehouse_phys.envs.base import OBSERVATION_KINDS, observation_space, onehot, status_line
from warehouse_phys.envs.checks import (
    checked_choice,
    checked_count,
    checked_penalties,
    checked_reset_mask,
    checked_vector_actions,
)
from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.world.batched import BatchedRules, step_rewards
from warehouse_phys.world.grid import Action, refuse_durations
from warehouse_phys.world.layouts import make_grid, suggested_time_limit

#: Most sub-environments in one vector environment (about 100 bytes of state each).
MAX_NUM_ENVS = 2**24

_ACTIONS: tuple[Action, ...] = tuple(Action)
#: Packages drawn from the generator at a time (see ``_draw_slots``).
TARGET_DRAWS = 4096
#: A (row, col) pair of int64 as one item, copied whole.
_PAIR = np.dtype("V16")


class WarehouseGridVectorEnv(VectorEnv):
    """``num_envs`` warehouse floors with the grid twin's rules, stepped as arrays.

    ## Description
    Each sub-environment is exactly a :class:`~warehouse_phys.envs.WarehouseGridEnv`
    made through ``gym.make`` (with its time limit): the same floor, moves,
    rewards, terminations, truncations and ``info["optimal_steps"]``. The rules
    come from :class:`~warehouse_phys.world.batched.BatchedRules`, look-up tables
    derived from the one :class:`~warehouse_phys.world.grid.WarehouseGrid`; a step is
    a few array operations over all floors, with no Python loop over them.

    ## Action Space
    ``MultiDiscrete([4] * num_envs)`` (``single_action_space`` is ``Discrete(4)``):
    LEFT=0, DOWN=1, RIGHT=2, UP=3. ``step`` takes an integer array of shape
    ``(num_envs,)`` in either byte order, a list or tuple of Python or numpy
    integers (converted one by one, never through float: ``[np.int8(2),
    np.uint64(1), 0]`` is an action), or anything else ``numpy.asarray`` makes
    an integer array of. Another shape or dtype raises ``TypeError``/``ValueError``,
    and so does a bool or a float in a list, a value outside 0..3 (``2**63`` and
    beyond too) or a masked one, naming the sub-environment; a refused step or
    reset (a bad seed or option) changes nothing.

    ## Observation Space
    ``MultiDiscrete`` of shape ``(num_envs, 4)``, int64: row ``i`` is sub-environment
    ``i``'s ``[robot_row, robot_col, target_row, target_col]``
    (``single_observation_space`` is ``MultiDiscrete([R, C, R, C])``). A fresh
    array every time. With ``observation="onehot"``: ``Box(0, 1, (num_envs,
    R + C + R + C), float32)``, each row the single environment's one-hot
    observation (see :class:`~warehouse_phys.envs.WarehouseGridEnv`).

    ## Starting State
    Every robot on the start cell; every package drawn uniformly from the
    floor's target cells, all from the vector environment's one ``np_random``
    (seeded by ``reset(seed=...)``, like Gymnasium's ``CartPoleVectorEnv``).

    ## Rewards
    1.0 to a sub-environment on the step its robot reaches its package, else 0.0
    (float64), less ``step_penalty`` on every step that does not reach it and
    ``bump_penalty`` on every step whose move a wall or shelf refuses, exactly as
    in the single environment (both default to 0.0). The step that restarts a
    sub-environment (next-step autoreset) gives it 0.0.

    ## Episode End
    A sub-environment terminates on its package and is truncated when its episode
    reaches ``max_episode_steps`` actions (both can hold at once, as with
    Gymnasium's ``TimeLimit``). Episodes restart on the *next* step
    (``metadata["autoreset_mode"]`` is ``NEXT_STEP``, as in ``SyncVectorEnv``):
    that step ignores the sub-environment's action, returns its new episode's
    first observation with reward 0 and neither flag set.

    ``reset(options={"reset_mask": mask})`` restarts only the sub-environments
    where the boolean array ``mask`` (shape ``(num_envs,)``) is true; a mask with
    no true value or with a masked entry (a ``numpy.ma`` array) raises ``ValueError``.

    ``infos`` holds ``"optimal_steps"`` (int64, the fewest actions left to each
    package) and its mask ``"_optimal_steps"``, as ``SyncVectorEnv`` gives them.

    ## Arguments
    - ``num_envs`` (int, default 1): how many floors, 1 to ``MAX_NUM_ENVS``.
    - ``grid_rows``, ``grid_cols``, ``layout``, ``cell_px``: as in
      :class:`~warehouse_phys.envs.WarehouseGridEnv`.
    - ``max_episode_steps`` (int): the time limit; ``gym.make_vec`` passes the
      id's (200 on the default floor, each preset's own); made directly, the
      floor's :func:`~warehouse_phys.world.layouts.suggested_time_limit`.
    - ``render_mode`` (``None``, ``"rgb_array"`` or ``"ansi"``): ``render()``
      returns a tuple with one frame per sub-environment.
    - Keyword-only: ``observation`` (``"cells"`` or ``"onehot"``), ``step_penalty``
      and ``bump_penalty`` (finite numbers >= 0 with a finite sum), checked as in
      the single environment.

    ```python
    import gymnasium as gym
    import numpy as np
    import warehouse_phys

    envs = gym.make_vec("warehouse-robot-v0", num_envs=1024)
    obs, infos = envs.reset(seed=0)  # obs.shape == (1024, 4)
    obs, rewards, terminations, truncations, infos = envs.step(np.full(1024, 2))
    ```

    ## Version History
    - v0: first version.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - Gymnasium reads this class attribute
        "render_modes": ["rgb_array", "ansi"],
        "render_fps": 4,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }
    #: The physics world's parameters; ``None`` in the grid twin.
    physics: PhysicsConfig | None = None

    def __init__(
        self,
        num_envs: int = 1,
        grid_rows: int | None = None,
        grid_cols: int | None = None,
        layout: str | Sequence[str] | None = None,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        cell_px: int = DEFAULT_CELL_PX,
        *,
        observation: str = "cells",
        step_penalty: float = 0.0,
        bump_penalty: float = 0.0,
    ) -> None:
        self.num_envs = checked_count("num_envs", num_envs, MAX_NUM_ENVS)
        refuse_durations(cell_px=cell_px)
        self.observation = checked_choice("observation", observation, OBSERVATION_KINDS)
        #: ``step_penalty`` is subtracted from the reward of every step that does not
        #: reach the package, ``bump_penalty`` from that of every move a wall or shelf refuses.
        self.step_penalty, self.bump_penalty = checked_penalties(step_penalty, bump_penalty)
        self.grid = make_grid(grid_rows, grid_cols, layout)
        self.grid_rows, self.grid_cols = self.grid.rows, self.grid.cols
        if max_episode_steps is None:
            max_episode_steps = suggested_time_limit(self.grid)
        self.max_episode_steps = checked_count("max_episode_steps", max_episode_steps, None)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.rules = BatchedRules(self.grid)

        self.single_action_space = spaces.Discrete(len(Action))
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.single_observation_space = observation_space(
            self.observation, self.grid_rows, self.grid_cols
        )
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        rules = self.rules
        # The state of every floor. A robot's cell is kept as 4 * index, so that
        # 4 * index + action looks up its move in one go; a (row, col) pair is
        # copied as one 16-byte item, so an observation is two array copies.
        self._moves4 = rules.moves * 4
        cell_rc = np.stack([rules.rows, rules.cols], axis=1).repeat(4, axis=0)
        self._cell_rc4 = np.ascontiguousarray(cell_rc).view(_PAIR).reshape(-1)
        self._distances4 = rules.distance_table(repeat=4)  # None on very large floors
        # What each package needs, by its slot in rules.targets.
        self._slot_target4 = rules.targets * 4
        self._slot_rc = self._cell_rc4[self._slot_target4]
        self._slot_base = np.arange(len(rules.targets), dtype=np.int64) * (4 * rules.n_cells)
        # Packages are drawn TARGET_DRAWS at a time from np_random and used in order.
        self._draws = np.empty(0, dtype=np.int64)
        self._drawn = 0
        self._pos4: np.ndarray | None = None  # (N,) int64: 4 * the robot's cell
        self._target4 = np.zeros(self.num_envs, dtype=np.int64)  # 4 * the package's cell
        self._target_rc = np.zeros(self.num_envs, dtype=_PAIR)  # the package's (row, col)
        self._target_base = np.zeros(self.num_envs, dtype=np.int64)  # its distance-table row
        self._steps = np.zeros(self.num_envs, dtype=np.int64)  # actions in this episode
        self._ended = np.empty(0, dtype=np.int64)  # the floors whose episode ended last step
        self._last_actions = np.full(self.num_envs, -1, dtype=np.int64)  # -1: none yet

        self._renderer = WarehouseRenderer.for_grid(
            self.grid, cell_px=cell_px, render_fps=self.metadata["render_fps"]
        )
        if render_mode == "rgb_array":
            self._renderer.check_frame_size()

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Move every robot by its action; restart the floors whose episode ended last step.

        Raises:
            gymnasium.error.ResetNeeded: if :meth:`reset` was never called.
            TypeError, ValueError: for actions the class docstring's Action Space
                refuses, naming the sub-environment; nothing changes then.
        """
        if self._pos4 is None:
            raise ResetNeeded("call reset() before step()")
        actions = checked_vector_actions(actions, self.num_envs)
        pos4 = self._move_robots(actions)
        terminated = pos4 == self._target4
        # A refused move leaves the robot on its cell.
        stayed = pos4 == self._pos4 if self.bump_penalty else None
        rewards = step_rewards(terminated, stayed, self.step_penalty, self.bump_penalty)
        steps = self._steps
        steps += 1
        truncated = steps >= self.max_episode_steps
        restart = self._ended if len(self._ended) else None
        if restart is not None:  # next-step autoreset of the floors that ended last step
            self._restart(restart, pos4)
            terminated[restart] = False
            truncated[restart] = False
            rewards[restart] = 0.0
        if self.render_mode is not None:  # the status lines name each floor's last action
            self._last_actions = actions.astype(np.int64)
            if restart is not None:
                self._last_actions[restart] = -1
        self._pos4 = pos4
        self._ended = np.flatnonzero(terminated | truncated)
        return (
            self._observations(),
            rewards,
            terminated,
            truncated,
            self._infos(),
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start new episodes on every floor, or on those ``options["reset_mask"]`` marks.

        Raises:
            TypeError, ValueError: for options other than ``reset_mask``, or a
                mask that is not a boolean array of shape ``(num_envs,)`` with
                at least one true value and no masked entry; nothing changes then.
        """
        mask = checked_reset_mask(options, self.num_envs)
        if mask is not None and self._pos4 is None:
            raise ResetNeeded("call reset() without a reset_mask first")
        super().reset(seed=seed)  # refuses a bad seed before anything has changed
        if seed is not None or mask is None:
            self._draws, self._drawn = np.empty(0, dtype=np.int64), 0  # a fresh stream
        if mask is None:
            self._start_all()
            mask = np.ones(self.num_envs, dtype=bool)
        self._restart(np.flatnonzero(mask), self._pos4)
        self._ended = self._ended[~mask[self._ended]]  # the others still restart next step
        infos = self._infos()
        if not mask.all():  # only the restarted sub-environments report
            for key in [key for key in infos if not key.startswith("_")]:
                infos[key][~mask] = 0
                infos[f"_{key}"] = mask
        return self._observations(), infos

    def render(self) -> tuple[np.ndarray, ...] | tuple[str, ...] | None:
        """One frame per sub-environment: ``(H, W, 3)`` uint8 arrays, or text in ``"ansi"``."""
        if self.render_mode is None:
            return None
        if self._pos4 is None:
            raise ResetNeeded("call reset() before render()")
        obs = self._cell_observations()
        frames = []
        for (row, col, target_row, target_col), action in zip(
            obs.tolist(), self._last_actions.tolist(), strict=True
        ):
            robot, target = (row, col), (target_row, target_col)
            if self.render_mode == "ansi":
                frames.append(
                    ansi_frame(self.grid_rows, self.grid_cols, robot, target, self.grid.shelves)
                )
            else:
                last = None if action < 0 else _ACTIONS[action]
                status = status_line(last, robot == target)
                frames.append(self._renderer.rgb_array(robot, target, status))
        return tuple(frames)

    def close_extras(self, **kwargs: Any) -> None:
        """Release the renderer's pygame resources."""
        self._renderer.close()

    # ------------------------------------------------------------------ helpers
    def _start_all(self) -> None:
        """Called by a reset of every floor once its arguments are accepted, before the
        robots are placed."""
        self._pos4 = np.zeros(self.num_envs, dtype=np.int64)

    def _move_robots(self, actions: np.ndarray) -> np.ndarray:
        """Where each robot ends after its action (``(N,)`` int64 actions), as 4 * its cell."""
        return self._moves4[self._pos4 + actions]

    def _restart(self, floors: np.ndarray, pos4: np.ndarray) -> None:
        """Put the robots of ``floors`` (indices) on the start, in ``pos4``, each with a
        freshly drawn package."""
        slots = self._draw_slots(len(floors))
        pos4[floors] = self.rules.start * 4
        self._target4[floors] = self._slot_target4[slots]
        self._target_rc[floors] = self._slot_rc[slots]
        self._target_base[floors] = self._slot_base[slots]
        self._steps[floors] = 0
        if self.render_mode is not None:
            self._last_actions[floors] = -1

    def _draw_slots(self, count: int) -> np.ndarray:
        """The next ``count`` packages, as slots of ``rules.targets``, each uniform.

        They come from ``np_random`` in blocks of :data:`TARGET_DRAWS` (or
        ``count``, if larger), used in order: the same seed gives the same
        packages in the same order, however the restarts fall.
        """
        if self._drawn + count > len(self._draws):
            block = max(TARGET_DRAWS, count)
            fresh = self.np_random.integers(len(self.rules.targets), size=block)
            self._draws = np.concatenate([self._draws[self._drawn :], fresh])
            self._drawn = 0
        slots = self._draws[self._drawn : self._drawn + count]
        self._drawn += count
        return slots

    def _observations(self) -> np.ndarray:
        obs = self._cell_observations()
        if self.observation == "onehot":
            return onehot(obs, self.grid_rows, self.grid_cols)
        return obs

    def _cell_observations(self) -> np.ndarray:
        """``[robot_row, robot_col, target_row, target_col]`` of every floor, ``(N, 4)``."""
        obs = np.empty((self.num_envs, 4), dtype=np.int64)
        pairs = obs.view(_PAIR)
        pairs[:, 0] = self._cell_rc4[self._pos4]
        pairs[:, 1] = self._target_rc
        return obs

    def _infos(self) -> dict[str, Any]:
        if self._distances4 is not None:
            optimal = self._distances4[self._target_base + self._pos4]
        else:
            optimal = self.rules.optimal_steps(self._pos4 >> 2, self._target4 >> 2)
        return {"optimal_steps": optimal, "_optimal_steps": np.ones(self.num_envs, dtype=bool)}


#: Names of the physics vector environment, in :mod:`warehouse_phys.envs.vector_physics`
#: (which imports this module), still found here.
_PHYSICS_NAMES = ("MAX_PHYSICS_ENVS", "WarehousePhysicsVectorEnv")


def __getattr__(name: str) -> Any:
    if name in _PHYSICS_NAMES:
        from warehouse_phys.envs import vector_physics  # on demand: it imports this module

        return getattr(vector_physics, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
