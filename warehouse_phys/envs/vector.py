"""Native vector environments: many warehouse floors stepped at once, as arrays.

``gym.make_vec("warehouse-robot-v0", num_envs=N)`` returns
:class:`WarehouseGridVectorEnv` (the ``vector_entry_point`` of the grid twin's
ids), which steps every floor with a handful of array operations instead of a
Python loop over single environments. ``gym.make_vec("warehouse-robot-phys-v0",
num_envs=N)`` returns :class:`WarehousePhysicsVectorEnv`, the same semantics with
every robot a body in one pymunk space.

Its length is the two vector twins side by side (the physics one a subclass of the
grid one), each with its Gymnasium specification as its class docstring.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer, ansi_frame
from warehouse_phys.envs.base import (
    INTEGER_TYPES,
    OBSERVATION_KINDS,
    checked_choice,
    checked_penalties,
    checked_record_path,
    is_integer_scalar,
    number_text,
    observation_space,
    onehot,
    recording_world,
    status_line,
)
from warehouse_phys.physics import PhysicsConfig, check_controller, physics_config_from
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.world.batched import BatchedRules, step_rewards
from warehouse_phys.world.grid import Action, refuse_durations
from warehouse_phys.world.layouts import make_grid, suggested_time_limit

#: Most sub-environments in one vector environment (about 100 bytes of state each).
MAX_NUM_ENVS = 2**24
#: Most sub-environments in one physics vector environment: each floor's walls, robot
#: and controller take about 16 KB, so the largest takes about 1 GB and builds in 11 s.
MAX_PHYSICS_ENVS = 2**16

_ACTIONS: tuple[Action, ...] = tuple(Action)
_MUST = "actions must be integers in 0..3 (LEFT=0, DOWN=1, RIGHT=2, UP=3)"
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
        self.num_envs = _checked_count("num_envs", num_envs, MAX_NUM_ENVS)
        refuse_durations(cell_px=cell_px)
        self.observation = checked_choice("observation", observation, OBSERVATION_KINDS)
        #: ``step_penalty`` is subtracted from the reward of every step that does not
        #: reach the package, ``bump_penalty`` from that of every move a wall or shelf refuses.
        self.step_penalty, self.bump_penalty = checked_penalties(step_penalty, bump_penalty)
        self.grid = make_grid(grid_rows, grid_cols, layout)
        self.grid_rows, self.grid_cols = self.grid.rows, self.grid.cols
        if max_episode_steps is None:
            max_episode_steps = suggested_time_limit(self.grid)
        self.max_episode_steps = _checked_count("max_episode_steps", max_episode_steps, None)
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
        actions = self._checked_actions(actions)
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
        mask = self._checked_reset_mask(options)
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

    def _checked_actions(self, actions: Any) -> np.ndarray:
        if type(actions) is not np.ndarray:
            actions = self._actions_array(actions)
        if actions.shape != (self.num_envs,):
            raise ValueError(
                f"actions must have shape ({self.num_envs},), one per sub-environment, "
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

    def _actions_array(self, actions: Any) -> np.ndarray:
        """``actions`` (a list, a masked array, ...) as a plain array, or a one-line error."""
        if isinstance(actions, np.ma.MaskedArray):
            if actions.shape == (self.num_envs,):  # another shape: the caller's shape error
                self._refuse_masked(np.ma.getmaskarray(actions))
            return np.asarray(actions.data)
        if isinstance(actions, (list, tuple)):
            return self._list_actions(actions)
        try:
            return np.asarray(actions)
        except (TypeError, ValueError) as error:
            raise self._no_array(actions, error) from None

    def _list_actions(self, items: list | tuple) -> np.ndarray:
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
        self._refuse_masked(np.array([np.ma.is_masked(item) for item in items], dtype=bool))
        for index, item in enumerate(items):
            if isinstance(item, (bool, np.bool_)):  # numpy would make 1 of True
                raise TypeError(f"{_MUST}: sub-environment {index}'s is a bool, not an integer")
        if all(is_integer_scalar(item) for item in items):  # 0-d arrays, other byte orders
            return self._list_actions([int(item) for item in items])
        try:
            return np.asarray(items)
        except (TypeError, ValueError) as error:  # a ragged list, say
            raise self._no_array(items, error) from None

    def _refuse_masked(self, masked: np.ndarray) -> None:
        if masked.any():
            raise ValueError(f"{_MUST}: sub-environment {np.flatnonzero(masked)[0]}'s is masked")

    def _no_array(self, actions: Any, error: Exception) -> ValueError:
        return ValueError(
            f"actions must be an array of shape ({self.num_envs},) of integers in 0..3; "
            f"numpy cannot make an array of this {type(actions).__name__}: "
            f"{str(error).splitlines()[0]}"
        )

    def _checked_reset_mask(self, options: dict[str, Any] | None) -> np.ndarray | None:
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
        if mask.shape != (self.num_envs,):
            raise ValueError(
                f"options['reset_mask'] must have shape ({self.num_envs},), got {mask.shape}"
            )
        if np.ma.is_masked(mask):  # a masked entry says neither restart nor keep
            raise ValueError(
                f"options['reset_mask'] has a masked entry (sub-environment "
                f"{np.flatnonzero(np.ma.getmaskarray(mask))[0]}): every entry must be a bool"
            )
        mask = np.array(mask)  # a plain copy, whatever the subclass
        if not mask.any():
            raise ValueError("options['reset_mask'] must mark at least one sub-environment")
        return mask


def _checked_count(name: str, value: object, maximum: int | None) -> int:
    if isinstance(value, (bool, np.timedelta64)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < 1 or (maximum is not None and value > maximum):
        limit = f"1 to {maximum}" if maximum is not None else "at least 1"
        raise ValueError(f"{name} must be {limit}, got {number_text(value)}")
    return int(value)


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
        _checked_count("num_envs", num_envs, MAX_PHYSICS_ENVS)
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
