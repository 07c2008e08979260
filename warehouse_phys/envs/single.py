"""The Gymnasium environments of the package.

:class:`WarehouseEnvBase` holds everything an episode needs (spaces, argument
checks, reset options, the reward rule, observations, rendering). A concrete
environment only says how the robot gets from one cell to the next by
overriding ``WarehouseEnvBase._move_robot``: the grid twin applies the rule
of :class:`~warehouse_phys.world.grid.WarehouseGrid` directly, the physics-backed
environment drives a pymunk body there and reads the cell back from it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from warehouse_phys.envs.base import WarehouseEnvBase, checked_record_path, recording_world
from warehouse_phys.physics import CAN_RESTART, PhysicsConfig, PhysicsWorld, check_controller
from warehouse_phys.world.grid import Action, Cell, move_table

_PHYSICS_DEFAULTS = PhysicsConfig()


class WarehouseGridEnv(WarehouseEnvBase):
    """A robot on a warehouse floor must reach a package: the pure-grid environment.

    ## Description
    The floor is a grid of ``grid_rows`` x ``grid_cols`` cells (4 x 5 by default);
    cells are ``(row, col)`` with row 0 at the top. A robot starts in the top-left
    cell and must drive to the cell of a package placed at random. This is the
    "grid twin": it moves the robot with integer arithmetic, and the
    physics-backed environment follows exactly the same rules.

    With ``layout=`` the floor is a warehouse with shelves instead: a preset
    name (``"aisles"``, ``"depot"``, ``"maze"``) or rows of text, ``.`` floor,
    ``#`` shelf, ``P`` a cell where packages may appear, ``S`` the start (the
    first ``S``, if a fleet layout marks several; see
    :meth:`warehouse_phys.world.grid.WarehouseGrid.from_layout`). The presets are
    also registered as ``warehouse-robot-<name>-v0``.

    ## Action Space
    ``Discrete(4)``:

    | Value | Name  | Move         |
    |-------|-------|--------------|
    | 0     | LEFT  | column - 1   |
    | 1     | DOWN  | row + 1      |
    | 2     | RIGHT | column + 1   |
    | 3     | UP    | row - 1      |

    The names are :class:`warehouse_phys.Action`. A move off the floor or into
    a shelf leaves the robot where it is; it still counts as a step. Python ints, numpy
    integers and 0-d integer arrays (in either byte order) are accepted; anything
    else (a bool, a float, a ``timedelta64``) raises ``TypeError``, an integer
    outside 0..3 (``2**63``, ``np.uint64(2**63)`` or one of thousands of digits
    too) or a masked value (``np.ma.masked``, a masked 0-d array) raises
    ``ValueError``, and the environment is unchanged by either.

    ## Observation Space
    ``MultiDiscrete([R, C, R, C])`` with dtype ``int64``: a fresh array
    ``[robot_row, robot_col, target_row, target_col]`` every time, so
    ``q[tuple(obs)]`` indexes a Q-table of shape ``(R, C, R, C, 4)`` directly.

    With ``observation="onehot"`` (for neural networks: an MLP policy reads it
    as it is): ``Box(0, 1, (R + C + R + C,), float32)``, the same four numbers
    one-hot encoded one after the other, so exactly four entries are 1.0:
    ``robot_row``, ``R + robot_col``, ``R + C + target_row`` and
    ``2R + C + target_col`` (:func:`~warehouse_phys.envs.base.onehot`).

    ## Starting State
    The robot stands on (0, 0). The target is drawn uniformly from rows 1..R-1
    and columns 1..C-1 (never row 0 or column 0, so never on the start) with
    ``self.np_random``, seeded by ``reset(seed=...)``. On a layout the robot
    starts on ``S`` (or (0, 0)) and the target is drawn from the ``P`` cells,
    or without any from every floor cell the robot can reach but the start.

    ``reset(options=...)`` may override both: ``{"target": (r, c)}`` places the
    package on any allowed cell without a random draw, ``{"start": (r, c)}``
    puts the robot on any other reachable floor cell (a random target is then drawn
    uniformly from the allowed cells other than the start). Evaluations use the
    first to try every target in turn.

    ## Rewards
    1.0 on the step that puts the robot on the target, 0.0 on every other step
    (the defaults). Two keywords shape it for deep RL, whose value-based agents
    can drift away from a sparse reward that costs nothing to delay:

    - ``step_penalty`` (float >= 0, default 0.0) is subtracted on every step
      that does not put the robot on the target;
    - ``bump_penalty`` (float >= 0, default 0.0) is subtracted on every step
      whose move a wall or a shelf refuses (the robot stays where it was).

    Both apply on the same step when a refused move leaves the robot off the
    target: ``-(step_penalty + bump_penalty)``. A value that is not a finite
    real number >= 0 (an integer too large for a float included) raises
    ``TypeError`` or ``ValueError`` naming it, and two whose sum is infinite
    raise ``ValueError``. Numpy numbers are accepted and kept as Python floats.

    ## Episode End
    - Termination: the robot stands on the target.
    - Truncation: the registered time limit, 200 steps by default. A uniformly
      random walk on the default 4 x 5 floor needs 45 steps on average and ends
      within 200 steps in 98.6 % of episodes. Bigger floors need longer:
      ``gym.make("warehouse-robot-v0", grid_rows=8, grid_cols=8, max_episode_steps=700)``.
      Each preset's id has the limit that gives the same 98 % (1200, 1500 and
      900 steps for ``aisles``, ``depot`` and ``maze``);
      :func:`warehouse_phys.world.layouts.suggested_time_limit` gives one for any
      floor (exact up to 100 reachable cells, 12 steps per cell beyond).

    Stepping on after termination is allowed and follows the same rules, as in
    Gymnasium's toy-text environments; call ``reset()`` to start a new episode.

    ``info`` holds ``"optimal_steps"``: the fewest actions from the robot's
    cell to the target (the Manhattan distance on an empty floor, a
    breadth-first search around shelves).

    ## Arguments
    - ``grid_rows`` (int, default 4), ``grid_cols`` (int, default 5): the floor's
      size; each must be an integer from 2 to 2048, or ``TypeError`` or
      ``ValueError`` says why. With a layout they come from it and may be left
      out (given, they must match it).
    - ``layout`` (preset name, list of strings or ``None``): a floor with
      shelves, described above. A layout that is ragged, uses an unknown
      symbol, puts the start on a shelf, has package cells the robot cannot
      reach or no cell for a package raises ``ValueError`` naming the row and
      column.
    - ``render_mode`` (``None``, ``"human"``, ``"rgb_array"`` or ``"ansi"``):
      ``"rgb_array"`` returns an ``(H, W, 3)`` uint8 frame and never needs a
      display; ``"human"`` draws in a pygame window paced at
      ``metadata["render_fps"]`` (closing it or pressing Escape stops the
      drawing, never the process: see :attr:`user_closed_window`); ``"ansi"``
      returns one text line per row, each cell as ``R``, ``T``, ``#`` (shelf)
      or ``_`` and a space. Frames show a status line with the last action
      under the grid; when the robot stands on the package it carries it, the
      cell is framed in green and the status line says "Delivered!". A frame
      larger than ``warehouse_phys.drawing.render.MAX_FRAME_PIXELS`` is refused when
      the environment is built; lower ``cell_px``. With no display, ``"human"``
      warns once and draws offscreen, as Gymnasium's own environments do (see
      :func:`~warehouse_phys.envs.base.draw_offscreen_without_display`). A
      ``render_mode`` that is not a string raises ``TypeError``, in ``gym.make`` too.
    - ``cell_px`` (int, default 64): side of one cell in rendered frames, in pixels.
    - Keyword-only: ``observation`` (``"cells"``, the default, or ``"onehot"``;
      see Observation Space), ``step_penalty`` and ``bump_penalty`` (see Rewards).

    ```python
    import gymnasium as gym
    import warehouse_phys  # registers the environments

    env = gym.make("warehouse-robot-v0", render_mode="ansi")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(warehouse_phys.Action.DOWN)
    ```

    The environment can be copied (``copy.deepcopy``) and pickled at any time;
    the copy continues exactly as the original would.
    """

    def _move_robot(self, action: Action) -> Cell:
        moves = self._moves
        if moves is None:
            return self.grid.move(self._robot, action)
        robot = self._robot
        return moves[robot[0]][robot[1]][action]

    def _start_episode(self) -> None:
        if self._moves is None:  # built once; shared by every environment on the same floor
            self._moves = move_table(self.grid)


class WarehousePhysicsEnv(WarehouseEnvBase):
    """A robot on a warehouse floor must reach a package: the physics-backed environment.

    ## Description
    The same task and the same rules as :class:`WarehouseGridEnv`, on a floor
    simulated with pymunk. The robot is a round rigid body with mass and moment;
    the floor is bounded by static walls. Each action hands the next cell to a
    controller (a kinematic control body and a pivot joint with capped force
    and speed) that drives the body there through the physics in a fixed number
    of steps of a constant ``dt``. When the move ends, the cell is read from
    where the body actually is (the nearest cell centre), and the body is
    snapped onto that centre with zero velocity; it is never teleported during
    a move. The tests prove that this environment and the grid twin give the
    same observations, rewards, terminations and ``info`` for the same seed and
    actions.

    A move towards a wall is driven too: the robot bumps into the wall, which
    stops it, and drives back to the centre of its own cell in the last
    ``settle_time`` of the move (see :mod:`warehouse_phys.physics`). Like a
    move off the floor in the grid twin, it leaves the robot where it was.
    Shelves of a ``layout`` are static boxes filling their cells: the robot
    bumps into them the same way. The presets are registered as
    ``warehouse-robot-phys-<name>-v0``.

    ## Action Space
    ``Discrete(4)``: LEFT=0, DOWN=1, RIGHT=2, UP=3, as in :class:`WarehouseGridEnv`.

    ## Observation Space
    ``MultiDiscrete([R, C, R, C])`` with dtype ``int64``:
    ``[robot_row, robot_col, target_row, target_col]``, the robot's cell read
    from the body's position; with ``observation="onehot"`` the same four
    numbers one-hot encoded, as in :class:`WarehouseGridEnv`.

    ## Starting State
    As in :class:`WarehouseGridEnv`, with the body at rest on the start cell's
    centre. The target is drawn from ``self.np_random`` exactly as there, so the
    same seed places it on the same cell in both environments. Every reset
    makes the robot as newly built, in the same floor's space (see
    :meth:`~warehouse_phys.physics.PhysicsWorld.restart`), so no contact or
    solver state carries over: an episode is bit for bit what a new world
    gives, and a seed replays bit for bit. ``reset(options=...)`` takes the same
    ``"target"`` and ``"start"`` options.

    ## Rewards
    1.0 on the step that puts the robot on the target, 0.0 on every other step,
    less ``step_penalty`` and ``bump_penalty`` as in :class:`WarehouseGridEnv`
    (a move is refused when the robot bumps into a wall or shelf and ends on its
    own cell).

    ## Episode End
    As in :class:`WarehouseGridEnv`: termination on the target, truncation at
    the registered time limit (200 steps).

    ``info`` holds ``"optimal_steps"`` (as in the grid twin) and
    ``"snap_error"``: the distance between the body and the centre of its cell
    just before the snap, in cells (0.0 after a reset). It is always below
    ``SNAP_ERROR_BOUND`` (0.02 of a cell); the defaults keep it under 0.005.

    ## Arguments
    - ``grid_rows``, ``grid_cols``, ``render_mode``, ``cell_px``, ``layout`` and the
      keyword-only ``observation``, ``step_penalty``, ``bump_penalty``: as in
      :class:`WarehouseGridEnv`. ``"human"`` plays every move as smooth motion
      in real time (one frame per physics step at 60 fps with the defaults),
      then shows the snapped frame. ``"rgb_array"`` returns the frame after the
      move; :meth:`move_frames` gives the frames during it.
    - Physical parameters, keyword-only (:class:`~warehouse_phys.physics.PhysicsConfig`
      documents each): ``cell_size`` (1.0 m), ``robot_radius`` (0.3 m),
      ``robot_mass`` (20 kg), ``floor_damping`` (1.0 1/s), ``max_speed``
      (6 m/s) and ``max_force`` (3000 N) of the controller, its ``gain``
      (60 1/s), the physics step ``dt`` (1/60 s), ``move_duration`` (0.25 s:
      15 steps per action) and ``settle_time`` (0.1 s). Nonsense (a
      non-positive size, a robot wider than a cell, ``dt`` longer than a move,
      a speed that could cross a wall in one step, a value outside
      ``physics.SUPPORTED_RANGES``, more than 1000 steps a move) raises
      ``ValueError`` or ``TypeError`` naming the setting, and so does a
      controller that :func:`~warehouse_phys.physics.check_controller` finds
      would break a promise (a move that misses the snap bound or its cell, a
      disc deeper than ``PENETRATION_TOLERANCE`` in a wall or shelf). Every
      setting it accepts keeps ``snap_error`` below the bound and the disc on
      the floor, out of shelves, at every physics step.
    - ``record_path`` (bool or ``None``): whether each move records the body's
      positions for :attr:`last_move_path` and :meth:`move_frames`. ``None``
      (the default) records when rendering to ``"human"`` or ``"rgb_array"``
      and not otherwise, since recording makes a move about 40 % slower.

    Through ``gym.make`` the extra attributes are reached with
    ``env.unwrapped``:

    ```python
    import gymnasium as gym
    import warehouse_phys  # registers the environments

    env = gym.make("warehouse-robot-phys-v0", render_mode="rgb_array")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(warehouse_phys.Action.RIGHT)
    path = env.unwrapped.last_move_path  # (15, 2) positions in cells
    frames = env.unwrapped.move_frames()  # 15 frames of the move
    ```
    """

    # One frame per physics step with the default dt: a move plays in real time.
    metadata: dict[str, Any] = {**WarehouseEnvBase.metadata, "render_fps": 60}  # noqa: RUF012

    def __init__(
        self,
        *args: Any,
        cell_size: float = _PHYSICS_DEFAULTS.cell_size,
        robot_radius: float = _PHYSICS_DEFAULTS.robot_radius,
        robot_mass: float = _PHYSICS_DEFAULTS.robot_mass,
        floor_damping: float = _PHYSICS_DEFAULTS.floor_damping,
        max_speed: float = _PHYSICS_DEFAULTS.max_speed,
        max_force: float = _PHYSICS_DEFAULTS.max_force,
        gain: float = _PHYSICS_DEFAULTS.gain,
        dt: float = _PHYSICS_DEFAULTS.dt,
        move_duration: float = _PHYSICS_DEFAULTS.move_duration,
        settle_time: float = _PHYSICS_DEFAULTS.settle_time,
        record_path: bool | None = None,
        **keywords: Any,
    ) -> None:
        # The floor, rendering, observation and penalties: as in every single environment.
        super().__init__(*args, **keywords)
        #: The physical parameters, checked here; each reset builds its world from them.
        self.physics: PhysicsConfig = PhysicsConfig(
            cell_size=cell_size,
            robot_radius=robot_radius,
            robot_mass=robot_mass,
            floor_damping=floor_damping,
            max_speed=max_speed,
            max_force=max_force,
            gain=gain,
            dt=dt,
            move_duration=move_duration,
            settle_time=settle_time,
        )
        check_controller(self.physics)
        self.record_path = checked_record_path(record_path, self.render_mode)
        #: The pymunk world of the current episode, rebuilt by every reset.
        self.world: PhysicsWorld | None = None
        self._snap_error = 0.0

    @property
    def last_move_path(self) -> np.ndarray:
        """The body's positions after each physics step of the last move, before the snap.

        A fresh float64 array of shape ``(steps_per_move, 2)`` of ``(row, col)``
        in cell units (cell centres are whole numbers); empty after a reset.

        Raises:
            gymnasium.error.ResetNeeded: before the first reset.
            RuntimeError: if the environment does not record paths (see ``record_path``).
        """
        return recording_world(self.world, self.record_path, "last_move_path").last_path

    def move_frames(self) -> list[np.ndarray]:
        """The frames of the last move, one per physics step, as ``(H, W, 3)`` uint8 arrays.

        They show the body at each position of :attr:`last_move_path`, the last
        one just before the snap; :meth:`render` in ``"rgb_array"`` mode gives
        the snapped frame after them. Played at ``1 / dt`` frames per second
        (``metadata["render_fps"]`` with the defaults) they show the move in
        real time. Needs no display, whatever the render mode.
        """
        status = self._status_text()
        return [
            self._renderer.rgb_array(position, self._target, status)
            for position in self.last_move_path
        ]

    # ------------------------------------------------------------ hooks
    def _move_robot(self, action: Action) -> Cell:
        result = self.world.move(action)
        self._snap_error = result.snap_error
        return result.cell

    def _start_episode(self) -> None:
        if self.world is not None and CAN_RESTART:
            self.world.restart(self._robot)  # the same walls, a new robot: as a new world
        else:
            self.world = PhysicsWorld(
                self.grid, self.physics, self._robot, record_path=self.record_path
            )
        self._snap_error = 0.0

    def _show_move(self) -> None:
        self._renderer.title = self._window_title()
        # Real time: move_duration * render_fps frames, each the body's position
        # at the end of its frame interval; the last one is the snapped frame
        # that render() draws next.
        path = self.world.last_path
        steps = len(path)
        frames = max(1, round(self.physics.move_duration * self.metadata["render_fps"]))
        status = self._status_text()
        for frame in range(1, frames):
            step = math.ceil(frame * steps / frames) - 1
            if not self._renderer.show(path[step], self._target, status):
                return

    def _get_info(self) -> dict[str, Any]:
        return {
            "optimal_steps": self.grid.optimal_steps(self._robot, self._target),
            "snap_error": self._snap_error,
        }
