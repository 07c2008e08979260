"""What every single warehouse environment shares (:class:`WarehouseEnvBase`), and the
encodings the vector and fleet environments use too: observation spaces and one-hot
rows, status lines, recorded paths.

The checks the environments share (actions, penalties, choices) live in
:mod:`warehouse_phys.envs.checks`; their names still import from here.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping, Sequence
from collections.abc import Set as AbstractSet
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from warehouse_phys.drawing.display import NoDisplayError, check_display
from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer
from warehouse_phys.drawing.text_frames import ansi_frame
from warehouse_phys.envs.checks import (
    INTEGER_TYPES,
    checked_action,
    checked_choice,
    checked_penalties,
    checked_penalty,
    is_integer,
    is_integer_scalar,
    number_text,
)
from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.world.grid import Action, Cell, refuse_durations, step_reward
from warehouse_phys.world.layouts import make_grid

__all__ = [
    "INTEGER_TYPES",
    "OBSERVATION_KINDS",
    "RenderModes",
    "WarehouseEnvBase",
    "checked_choice",
    "checked_penalties",
    "checked_penalty",
    "checked_record_path",
    "draw_offscreen_without_display",
    "is_integer_scalar",
    "number_text",
    "observation_space",
    "onehot",
    "recording_world",
    "status_line",
]

_RESET_OPTIONS = ("start", "target")


#: The ``observation`` choices of the single and vector environments: ``"cells"`` (the
#: default), the four integers ``[robot_row, robot_col, target_row, target_col]``;
#: ``"onehot"``, the same four numbers one-hot encoded in one flat float32 vector.
OBSERVATION_KINDS = ("cells", "onehot")


class RenderModes(list):
    """The ``render_modes`` of a ``metadata``: a list of names that refuses to look up a non-name.

    ``gym.make(id, render_mode=1)`` asks ``1 in metadata["render_modes"]``
    before it builds the environment; with a plain list it then fails on
    ``1.endswith``. This list answers such a question with a ``TypeError``
    naming ``render_mode``, as ``1 in "abc"`` does.
    """

    def __contains__(self, mode: object) -> bool:
        if not isinstance(mode, str):
            raise TypeError(
                f"render_mode must be None or one of {list(self)}, got {mode!r} "
                f"({type(mode).__name__})"
            )
        return super().__contains__(mode)


class WarehouseEnvBase(gym.Env[np.ndarray, np.int64]):
    """What every warehouse environment shares; see
    :class:`~warehouse_phys.envs.single.WarehouseGridEnv` for the specification.

    Subclasses implement ``_move_robot(action) -> Cell`` and may extend
    ``_start_episode()`` (called at the end of every reset).
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - Gymnasium reads and copies this class attribute
        "render_modes": RenderModes(["human", "rgb_array", "ansi"]),
        "render_fps": 4,
    }
    #: The physics world's parameters; ``None`` in the grid twin.
    physics: PhysicsConfig | None = None

    def __init__(
        self,
        grid_rows: int | None = None,
        grid_cols: int | None = None,
        render_mode: str | None = None,
        cell_px: int = DEFAULT_CELL_PX,
        layout: str | Sequence[str] | None = None,
        *,
        observation: str = "cells",
        step_penalty: float = 0.0,
        bump_penalty: float = 0.0,
    ) -> None:
        refuse_durations(cell_px=cell_px)
        self.observation = checked_choice("observation", observation, OBSERVATION_KINDS)
        #: ``step_penalty`` is subtracted from the reward of every step that does not
        #: reach the package, ``bump_penalty`` from that of every move a wall or shelf refuses.
        self.step_penalty, self.bump_penalty = checked_penalties(step_penalty, bump_penalty)
        self._penalised = bool(self.step_penalty or self.bump_penalty)
        self.grid = make_grid(grid_rows, grid_cols, layout)
        self.grid_rows = self.grid.rows
        self.grid_cols = self.grid.cols
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode

        self.action_space = spaces.Discrete(len(Action))
        self.observation_space = observation_space(self.observation, self.grid_rows, self.grid_cols)

        self._robot: Cell | None = None
        self._target: Cell | None = None
        self._obs_template = np.zeros(4, dtype=np.int64)
        #: ``grid.move`` as nested lists, ``moves[row][col][action]``, on small floors.
        self._moves: list[list[tuple[Cell, ...]]] | None = None
        self._last_action: Action | None = None
        # Built in every mode so that a bad cell_px fails here; it loads no pygame until drawing.
        self._renderer = WarehouseRenderer.for_grid(
            self.grid,
            cell_px=cell_px,
            render_fps=self.metadata["render_fps"],
            title=f"warehouse_phys: {type(self).__name__}",
        )
        if render_mode in ("rgb_array", "human"):
            self._renderer.check_frame_size()
        if render_mode == "human":
            draw_offscreen_without_display()

    def step(
        self, action: int | np.integer
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Move the robot by ``action`` and report the new state. An action refused with
        ``TypeError`` or ``ValueError`` changes nothing.

        Raises:
            gymnasium.error.ResetNeeded: if :meth:`reset` was never called.
            TypeError: if ``action`` is not an integer (``None``, a float, a bool, ...).
            ValueError: if ``action`` is an integer outside ``0..3``.
        """
        if self._robot is None:
            raise ResetNeeded("call reset() before step()")
        move = checked_action(action)
        before = self._robot
        self._robot = self._move_robot(move)
        self._last_action = move
        terminated = self._robot == self._target
        reward = (
            step_reward(terminated, self._robot == before, self.step_penalty, self.bump_penalty)
            if self._penalised
            else step_reward(terminated)
        )
        if self.render_mode == "human":
            self._show_move()
            self.render()
        return self._get_obs(), reward, terminated, False, self._get_info()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode: robot on the start cell, target drawn with ``self.np_random``.

        ``options`` may hold ``"target"``, a cell from
        :attr:`WarehouseGrid.target_cells <warehouse_phys.world.grid.WarehouseGrid.target_cells>`
        to use instead of a random draw (no random number is drawn then), and
        ``"start"``, any floor cell other than the target for the robot to start on
        (a random target is then drawn from the other allowed cells).
        """
        start, target = self._parse_options(options)  # first, so bad options change nothing
        super().reset(seed=seed)
        if target is None:
            target = self.grid.sample_target(self.np_random, exclude=start)
        self._robot, self._target = start, target
        self._obs_template = np.array((0, 0, target[0], target[1]), dtype=np.int64)
        self._last_action = None
        self._start_episode()
        if self.render_mode == "human":
            self.render()
        return self._get_obs(), self._get_info()

    def render(self) -> np.ndarray | str | None:
        """Render the current state in ``render_mode`` (given when the environment is made).

        ``"rgb_array"`` returns an ``(H, W, 3)`` uint8 array, ``"ansi"`` a string,
        ``"human"`` draws in a window and returns ``None``.
        """
        if self.render_mode is None:
            gym.logger.warn(
                "You are calling render method without specifying any render mode. "
                "You can specify the render_mode at initialization, "
                f'e.g. gym.make("{self.spec.id if self.spec else type(self).__name__}", '
                'render_mode="rgb_array")'
            )
            return None
        if self._robot is None:
            raise ResetNeeded("call reset() before render()")
        if self.render_mode == "ansi":
            return ansi_frame(
                self.grid_rows, self.grid_cols, self._robot, self._target, self.grid.shelves
            )
        if self.render_mode == "rgb_array":
            return self._renderer.rgb_array(self._robot, self._target, self._status_text())
        self._renderer.title = self._window_title()
        self._renderer.show(self._robot, self._target, self._status_text())
        return None

    def close(self) -> None:
        """Close the window, if any, and release pygame; safe to call more than once."""
        self._renderer.close()

    @property
    def user_closed_window(self) -> bool:
        """Whether the user closed the ``human`` window or pressed Escape; drawing then stops."""
        return self._renderer.closed_by_user

    # ------------------------------------------------------------ for subclasses
    def _move_robot(self, action: Action) -> Cell:
        """Carry out ``action`` from the robot's current cell and return the cell it ends on."""
        raise NotImplementedError

    def _start_episode(self) -> None:
        """Called at the end of :meth:`reset`, once the robot and target cells are set."""

    def _show_move(self) -> None:
        """In ``human`` mode, called after each move and before its final frame is drawn."""

    # ------------------------------------------------------------------ helpers
    def _get_obs(self) -> np.ndarray:
        # A copy of this episode's [0, 0, target_row, target_col], with the robot's cell:
        # half the cost of building the array from four numbers.
        obs = self._obs_template.copy()
        robot = self._robot
        obs[0] = robot[0]
        obs[1] = robot[1]
        if self.observation == "onehot":
            return onehot(obs[None], self.grid_rows, self.grid_cols)[0]
        return obs

    def _get_info(self) -> dict[str, Any]:
        return {"optimal_steps": self.grid.optimal_steps(self._robot, self._target)}

    def _window_title(self) -> str:
        """The ``human`` window's caption: the id the environment was made with."""
        return f"warehouse_phys: {self.spec.id if self.spec else type(self).__name__}"

    def _status_text(self) -> str:
        return status_line(self._last_action, self._robot == self._target)

    def _parse_options(self, options: dict[str, Any] | None) -> tuple[Cell, Cell | None]:
        if options is None:
            return self.grid.start, None
        if not isinstance(options, Mapping):
            raise TypeError(
                f"reset options must be a dict or None, got {options!r} "
                f"({type(options).__name__}); known keys: {list(_RESET_OPTIONS)}"
            )
        unknown = [key for key in options if key not in _RESET_OPTIONS]
        if unknown:
            raise ValueError(
                f"unknown reset option(s) {', '.join(map(repr, unknown))}; "
                f"known: {list(_RESET_OPTIONS)}"
            )
        start = self.grid.start
        if options.get("start") is not None:
            start = self._checked_cell("start", options["start"])
            if not self.grid.is_free(start):
                raise ValueError(f"options['start'] {tuple(start)} is a shelf")
            if start not in self.grid.reachable:
                raise ValueError(
                    f"options['start'] {tuple(start)} cannot be reached from the layout's start"
                )
        target = None
        if options.get("target") is not None:
            target = self._checked_cell("target", options["target"])
            if target not in self.grid.target_cells:
                allowed = (
                    f"rows 1..{self.grid_rows - 1}, columns 1..{self.grid_cols - 1}"
                    if self.grid.layout is None
                    else "see grid.target_cells"
                )
                raise ValueError(
                    f"options['target'] {tuple(target)} is not a cell the target may occupy "
                    f"({allowed})"
                )
            if start == target:
                raise ValueError(f"options['start'] {tuple(start)} is the target's cell")
        elif set(self.grid.target_cells) <= {start}:
            raise ValueError(
                f"options['start'] {tuple(start)} is the only cell the target may occupy"
            )
        return start, target

    def _checked_cell(self, name: str, value: Any) -> Cell:
        if isinstance(value, (Mapping, AbstractSet)):  # unpacking would read keys in any order
            raise TypeError(
                f"options[{name!r}] must be a (row, col) pair, got {value!r} "
                f"({type(value).__name__}, which has no order)"
            )
        try:
            row, col = value
        except (TypeError, ValueError):
            raise ValueError(
                f"options[{name!r}] must be a (row, col) pair, got {value!r}"
            ) from None
        if not all(is_integer(v) for v in (row, col)):
            raise ValueError(f"options[{name!r}] must hold two integers, got {value!r}")
        cell = Cell(int(row), int(col))
        if not self.grid.contains(cell):
            raise ValueError(
                f"options[{name!r}] ({number_text(cell.row)}, {number_text(cell.col)}) "
                f"is off the {self.grid_rows}x{self.grid_cols} grid"
            )
        return cell


def status_line(last_action: Action | None, delivered: bool) -> str:
    """The status line under a frame: the last action, and whether the package arrived."""
    if last_action is None:
        return ""
    return f"Action: {last_action.name}{'   Delivered!' if delivered else ''}"


def checked_record_path(record_path: object, render_mode: str | None) -> bool:
    """Whether a physics-backed environment records paths: ``record_path``, or by default
    when it renders frames (``"human"`` or ``"rgb_array"``)."""
    if record_path is None:
        return render_mode in ("human", "rgb_array")
    if not isinstance(record_path, bool):
        raise TypeError(f"record_path must be a bool or None, got {record_path!r}")
    if render_mode == "human" and not record_path:
        raise ValueError("render_mode='human' plays the recorded path: record_path must be on")
    return record_path


def recording_world(world: Any, record_path: bool, name: str) -> Any:
    """``world``, if a reset built it and it records paths, to read ``name`` from.

    Raises:
        gymnasium.error.ResetNeeded: before the first reset.
        RuntimeError: if the environment does not record paths (see ``record_path``).
    """
    if world is None:
        raise ResetNeeded(f"call reset() before reading {name}")
    if not record_path:
        raise RuntimeError(
            "this environment does not record paths: create it with record_path=True "
            "or with render_mode='rgb_array'"
        )
    return world


def observation_space(observation: str, rows: int, cols: int) -> spaces.Space:
    """The single observation space of ``observation`` (see :data:`OBSERVATION_KINDS`):
    ``MultiDiscrete([R, C, R, C])``, or ``Box(0, 1, (R + C + R + C,), float32)``."""
    if observation == "onehot":
        return spaces.Box(0.0, 1.0, (2 * rows + 2 * cols,), np.float32)
    return spaces.MultiDiscrete([rows, cols, rows, cols])


def onehot(cells: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Rows of ``[row, col, target_row, target_col]`` (shape ``(N, 4)``) one-hot encoded.

    Returns a fresh ``(N, R + C + R + C)`` float32 array: in each row, a 1 at
    ``row``, at ``R + col``, at ``R + C + target_row`` and at ``2R + C + target_col``,
    0 elsewhere.
    """
    out = np.zeros((len(cells), 2 * rows + 2 * cols), dtype=np.float32)
    offsets = np.array([0, rows, rows + cols, 2 * rows + cols], dtype=np.int64)
    out[np.arange(len(cells))[:, None], cells + offsets] = 1.0
    return out


def draw_offscreen_without_display() -> None:
    """Let ``"human"`` rendering draw offscreen, with a warning, where there is no display.

    Gymnasium's own environments (CartPole, say) render ``"human"`` without a
    display, and its ``check_env`` makes every render mode, so a headless
    check or test must not fail here. Where :func:`~warehouse_phys.drawing.render.check_display`
    finds no display, this selects SDL's ``"dummy"`` video driver (frames are
    drawn, shown nowhere) and warns; the driver is then set for the whole
    process, so it warns once. It is set before pygame's display starts, and
    changes nothing in a display already started (which SDL, finding no
    display, started offscreen). A driver already chosen in ``SDL_VIDEODRIVER``
    is left alone, and ``python -m warehouse_phys.play`` still refuses to run
    without a display.
    """
    try:
        check_display()
    except NoDisplayError:
        os.environ["SDL_VIDEODRIVER"] = "dummy"
        warnings.warn(
            "render_mode='human' found no display (DISPLAY and WAYLAND_DISPLAY are unset): "
            "frames are drawn offscreen with SDL_VIDEODRIVER=dummy and shown nowhere; to see "
            "them, run in a desktop session, forward one with `ssh -X` or use `xvfb-run`",
            UserWarning,
            stacklevel=2,
        )
