"""A fleet of robots on one warehouse floor, as PettingZoo environments.

``warehouse_phys.fleet.parallel_env(**kwargs)`` returns a :class:`WarehouseFleetEnv`
(a PettingZoo ``ParallelEnv``); ``warehouse_phys.fleet.env(**kwargs)`` the same as
an AEC environment (PettingZoo's ``parallel_to_aec``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from warehouse_phys.batched_physics import ACTION_DELTA_ARRAY, BatchedPhysicsWorld
from warehouse_phys.envs import make_grid
from warehouse_phys.grid import Cell
from warehouse_phys.layouts import suggested_time_limit
from warehouse_phys.physics import check_controller, physics_config_from
from warehouse_phys.render import DEFAULT_CELL_PX, WarehouseRenderer
from warehouse_phys.traffic import (
    FLEET_ACTIONS,
    MAX_ROBOTS,
    WAIT,
    corner_follows_are_safe,
    resolve_moves,
)

_OBSERVATIONS = ("local", "global")


class WarehouseFleetEnv(ParallelEnv):
    """Several robots on one warehouse floor, each delivering its own packages.

    ## Description
    ``num_robots`` robots share one floor (the default 4 x 5, any size, or a
    layout). All move at once; the traffic rule of :mod:`warehouse_phys.traffic`
    decides which moves are granted (walls and shelves refuse a move; among
    robots heading for one cell the lowest-numbered goes; a robot heading for
    a cell whose occupant stays waits, repeated until nothing changes, so chains
    and rotations move together; swaps wait; corner follows only for robots
    small enough to pass). With ``physics=False`` the grid twin applies the
    rule to cells; with ``physics=True`` every robot is a body in one pymunk
    space (:class:`~warehouse_phys.batched_physics.BatchedPhysicsWorld`, shapes
    that collide with each other), each granted move is driven exactly as in
    the single physics environment and a waiting robot holds its cell's centre.
    The tests prove that the bodies end on the grid twin's cells, and that no
    two discs ever come closer than their diameter minus the collision slop.

    ## Action Space
    ``Discrete(5)`` per robot: LEFT=0, DOWN=1, RIGHT=2, UP=3 (as the single
    environments) and WAIT=4 (:data:`warehouse_phys.traffic.WAIT`). ``step``
    takes a dict with an action for every live robot; anything else raises
    ``ValueError``/``TypeError`` naming the robot and changes nothing.

    ## Observation Space
    ``observation="local"`` (default): each robot sees its own
    ``[row, col, package_row, package_col]`` (``MultiDiscrete([R, C, R, C])``),
    so one Q-table of shape ``(R, C, R, C, 5)`` serves every robot.
    ``observation="global"``: every robot sees every robot's four numbers, in
    robot order (``MultiDiscrete([R, C, R, C] * num_robots)``), as
    :meth:`state` returns.

    ## Starting State
    On a fleet layout, one with several ``S`` cells, robot ``i`` stands on the
    ``i``-th in reading order. Otherwise robot 0 stands on the floor's start
    and the others on the next cells a robot can reach in reading order (on a
    plain floor: the first cells of row 0, then of row 1, ...), so the presets
    take fleets too. Fewer start cells than robots, or too few package cells
    (see below), raises ``ValueError``. Each
    robot's package is drawn uniformly from the floor's package cells, never
    on a robot's cell or another robot's package, with the environment's
    generator (``reset(seed=...)``).

    ## Rewards
    1.0 to a robot on the step it reaches its package, else 0.0.

    ## Episode End
    Without ``lifelong``, a robot that reaches its package terminates and parks
    there, still an obstacle; the episode ends when all have terminated or at
    ``max_cycles`` steps (truncation). With ``lifelong=True`` a robot gets a
    new package at once and only the time limit ends the episode.

    ``infos[robot]`` holds ``optimal_steps`` (to its own package, ignoring the
    other robots), ``refused`` (whether traffic turned its move into a wait),
    ``deliveries`` (packages delivered this episode) and, in the physics world,
    ``snap_error`` and ``min_gap``: the smallest distance between its disc and
    another robot's during the step [cells] (negative: the discs overlapped).

    ## Arguments
    - ``num_robots`` (int, default 2): 1 to :data:`MAX_ROBOTS`.
    - ``physics`` (bool, default False), and the physical keywords of
      :class:`~warehouse_phys.envs.WarehousePhysicsEnv` (``robot_radius`` ...),
      which also decide for the grid twin whether corner follows are granted.
    - ``grid_rows``, ``grid_cols``, ``layout``: the floor, as in the single environments.
    - ``lifelong`` (bool, default False), ``max_cycles`` (int; default
      :func:`~warehouse_phys.layouts.suggested_time_limit` of the floor, the
      single environments' limit), ``observation`` (``"local"`` or ``"global"``),
      ``render_mode`` (``None``, ``"rgb_array"``: every robot in a ring of its own
      colour, its package framed in the same colour; or ``"ansi"``: robots as
      digits, packages as letters), ``cell_px``. :meth:`move_frames` gives the
      physics world's motion during the last step, one frame per physics step.

    ## Version History
    - v0: first version.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - PettingZoo reads this class attribute
        "name": "warehouse_fleet_v0",
        "render_modes": ["rgb_array", "ansi"],
        "render_fps": 4,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        num_robots: int = 2,
        physics: bool = False,
        grid_rows: int | None = None,
        grid_cols: int | None = None,
        layout: str | Sequence[str] | None = None,
        lifelong: bool = False,
        max_cycles: int | None = None,
        observation: str = "local",
        render_mode: str | None = None,
        cell_px: int = DEFAULT_CELL_PX,
        **physical: float,
    ) -> None:
        if isinstance(num_robots, bool) or not isinstance(num_robots, (int, np.integer)):
            raise TypeError(f"num_robots must be an integer, got {num_robots!r}")
        if not 1 <= num_robots <= MAX_ROBOTS:
            raise ValueError(f"num_robots must be 1 to {MAX_ROBOTS}, got {num_robots}")
        for name, flag in (("physics", physics), ("lifelong", lifelong)):
            if not isinstance(flag, bool):
                raise TypeError(f"{name} must be a bool, got {flag!r}")
        if observation not in _OBSERVATIONS:
            raise ValueError(
                f"observation must be one of {list(_OBSERVATIONS)}, got {observation!r}"
            )
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        self.grid = make_grid(grid_rows, grid_cols, layout)
        self.num_robots = int(num_robots)
        self.physics = physics
        self.lifelong = lifelong
        self.observation = observation
        self.render_mode = render_mode
        if max_cycles is None:
            max_cycles = suggested_time_limit(self.grid)
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, (int, np.integer)):
            raise TypeError(f"max_cycles must be an integer, got {max_cycles!r}")
        if max_cycles < 1:
            raise ValueError(f"max_cycles must be at least 1, got {max_cycles}")
        self.max_cycles = int(max_cycles)
        #: The physical parameters (checked even for the grid twin: they decide corner follows).
        self.config = physics_config_from(physical)
        if physics:
            check_controller(self.config)
        self.corner_follows = corner_follows_are_safe(
            2 * self.config.robot_radius / self.config.cell_size
        )
        self.starts = self._start_cells()
        # Every draw must find a cell: at a reset, away from the starts; in a lifelong
        # episode, away from the other robots and their packages wherever they stand.
        targets = set(self.grid.target_cells)
        needed, room = self.num_robots, len(targets - set(self.starts))
        if lifelong:
            needed, room = 2 * self.num_robots - 1, len(targets)
        if room < needed:
            where = (
                " (lifelong: one for every robot and package but the one drawn)"
                if lifelong
                else " away from the starts"
            )
            raise ValueError(
                f"{self.num_robots} robots need {needed} package cells{where}; "
                f"this floor has {room}"
            )

        self.possible_agents = [f"robot_{i}" for i in range(self.num_robots)]
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        rows, cols = self.grid.rows, self.grid.cols
        self._local_space = spaces.MultiDiscrete([rows, cols, rows, cols])
        self.state_space = spaces.MultiDiscrete([rows, cols, rows, cols] * self.num_robots)
        self._action_space = spaces.Discrete(FLEET_ACTIONS)

        self.np_random, _ = seeding.np_random(None)
        self._cells: list[Cell] = []
        self._packages: list[Cell] = []
        self._parked = np.zeros(self.num_robots, dtype=bool)
        self._deliveries = np.zeros(self.num_robots, dtype=np.int64)
        self._steps = 0
        self.world: BatchedPhysicsWorld | None = None
        self._renderer = WarehouseRenderer.for_grid(
            self.grid, cell_px=cell_px, render_fps=self.metadata["render_fps"]
        )
        if render_mode == "rgb_array":
            self._renderer.check_frame_size()

    def observation_space(self, agent: str) -> spaces.MultiDiscrete:
        """The observation space of ``agent`` (the same object on every call)."""
        self._checked_agent(agent)
        return self._local_space if self.observation == "local" else self.state_space

    def action_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(5)``: the four moves and WAIT (the same object on every call)."""
        self._checked_agent(agent)
        return self._action_space

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Every robot on its start cell with a new package; ``seed`` seeds the generator.

        ``options`` are accepted and ignored (PettingZoo's test suites pass some).
        """
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        self.agents = list(self.possible_agents)
        self._cells = list(self.starts)
        self._packages = []
        for i in range(self.num_robots):
            self._packages.append(self._draw_package(i))
        self._parked[:] = False
        self._deliveries[:] = 0
        self._steps = 0
        if self.physics:
            self.world = BatchedPhysicsWorld(
                self.grid,
                self.config,
                self._cells,
                np.zeros(self.num_robots, dtype=np.int64),
                record_path=True,
            )
        refused = [False] * self.num_robots
        infos = self._infos(refused, np.zeros(self.num_robots), None)
        return self._observations(), infos

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        """Move every live robot by its action under the traffic rule."""
        if not self.agents:
            raise ValueError("the episode is over (no live robots): call reset()")
        joint = self._checked_actions(actions)
        ends, refused = resolve_moves(
            self.grid, self._cells, joint, self._parked, corner_follows=self.corner_follows
        )
        ends = [Cell(r, c) for r, c in ends.tolist()]
        snap_errors, gaps = np.zeros(self.num_robots), None
        if self.physics:
            ends, snap_errors, gaps = self._drive(joint, ends)
        self._cells = ends
        self._steps += 1
        rewards = {}
        terminations = {}
        for agent in self.agents:
            i = self._index[agent]
            arrived = ends[i] == self._packages[i]
            rewards[agent] = 1.0 if arrived else 0.0
            if arrived:
                self._deliveries[i] += 1
                if self.lifelong:
                    self._packages[i] = self._draw_package(i)
                else:
                    self._parked[i] = True
            terminations[agent] = bool(arrived and not self.lifelong)
        truncated = self._steps >= self.max_cycles
        truncations = {agent: truncated and not terminations[agent] for agent in self.agents}
        observations = self._observations()
        infos = self._infos(refused, snap_errors, gaps)
        self.agents = [
            agent for agent in self.agents if not (terminations[agent] or truncations[agent])
        ]
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | str | None:
        """``"rgb_array"``: every robot in its colour with its package; ``"ansi"``: text."""
        if self.render_mode is None:
            return None
        if not self._cells:
            raise ValueError("call reset() before render()")
        if self.render_mode == "ansi":
            return self._ansi()
        positions = self.world.positions().tolist() if self.world is not None else self._cells
        return self._renderer.fleet_rgb_array(positions, self._packages)

    def move_frames(self) -> list[np.ndarray]:
        """The frames of the last step's motion in the physics world, one per physics step
        (the last just before the snap), as ``(H, W, 3)`` uint8 arrays; needs no display.

        Raises:
            ValueError: in the grid twin, which has no motion between cells.
        """
        if self.world is None:
            raise ValueError("only the physics world (physics=True) has motion frames")
        paths = self.world.last_paths  # (K, steps, 2)
        return [
            self._renderer.fleet_rgb_array(paths[:, step].tolist(), self._packages)
            for step in range(paths.shape[1])
        ]

    def close(self) -> None:
        """Release the renderer's pygame resources."""
        self._renderer.close()

    def state(self) -> np.ndarray:
        """The global picture: every robot's ``[row, col, package_row, package_col]``."""
        return np.array(
            [v for cell, package in zip(self._cells, self._packages, strict=True)
             for v in (*cell, *package)],
            dtype=np.int64,
        )  # fmt: skip

    # ------------------------------------------------------------------ helpers
    def _drive(
        self, joint: list[int], ends: list[Cell]
    ) -> tuple[list[Cell], np.ndarray, np.ndarray]:
        """Drive the granted moves (and bumps into walls) in the physics; hold the rest."""
        cells = np.array(self._cells, dtype=np.int64)
        moves = np.array([a if a != WAIT else 0 for a in joint], dtype=np.int64)
        aims = cells + ACTION_DELTA_ARRAY[moves]
        granted = np.array([end != cell for end, cell in zip(ends, self._cells, strict=True)])
        # A move the floor refuses is driven too: the robot bumps and drives back, as alone.
        bumps = np.array(
            [a != WAIT and not self._parked[i] and self.grid.move(cell, a) == cell
             for i, (cell, a) in enumerate(zip(self._cells, joint, strict=True))]
        )  # fmt: skip
        hold = ~(granted | bumps)
        aims[hold] = cells[hold]
        body_cells, snap_errors = self.world.move(aims)
        paths = self.world.last_paths  # (K, steps, 2) in cells
        gaps = np.full(self.num_robots, np.inf)
        if self.num_robots > 1:
            diameter = 2 * self.config.robot_radius / self.config.cell_size
            apart = np.linalg.norm(paths[:, None] - paths[None, :], axis=-1).min(axis=-1)
            np.fill_diagonal(apart, np.inf)
            gaps = apart.min(axis=1) - diameter
        return [Cell(int(r), int(c)) for r, c in body_cells], snap_errors, gaps

    def _checked_actions(self, actions: object) -> list[int]:
        if not isinstance(actions, dict):
            raise TypeError(
                f"actions must be a dict of robot to action, got {type(actions).__name__}"
            )
        unknown = [agent for agent in actions if agent not in self.agents]
        if unknown:
            raise ValueError(
                f"actions for robots that are not live: {unknown}; live: {self.agents}"
            )
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {missing}")
        joint = [WAIT] * self.num_robots
        for agent, action in actions.items():
            is_integer = isinstance(action, (int, np.integer)) or (
                isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu"
            )
            if isinstance(action, (bool, np.bool_)) or not is_integer:
                raise TypeError(f"{agent}'s action must be an integer 0..4, got {action!r}")
            if not 0 <= int(action) < FLEET_ACTIONS:
                raise ValueError(f"{agent}'s action must be 0..4 (4 is WAIT), got {action!r}")
            joint[self._index[agent]] = int(action)
        return joint

    def _checked_agent(self, agent: str) -> None:
        if agent not in self._index:
            raise ValueError(f"unknown robot {agent!r}; the robots are {self.possible_agents}")

    def _start_cells(self) -> list[Cell]:
        """A fleet layout's ``S`` cells; else the floor's start, then the other cells robots
        can reach in reading order."""
        marked = self.grid.starts
        if len(marked) > 1:
            if len(marked) < self.num_robots:
                raise ValueError(
                    f"{self.num_robots} robots need {self.num_robots} start cells; the layout "
                    f"marks {len(marked)} ('S')"
                )
            return list(marked[: self.num_robots])
        start = self.grid.start
        others = sorted(cell for cell in self.grid.reachable if cell != start)
        if len(others) + 1 < self.num_robots:
            raise ValueError(
                f"{self.num_robots} robots need {self.num_robots} start cells; this floor has "
                f"{len(others) + 1} cells a robot can reach"
            )
        return [start, *others[: self.num_robots - 1]]

    def _draw_package(self, robot: int) -> Cell:
        taken = set(self._cells) | {p for i, p in enumerate(self._packages) if i != robot}
        choices = [cell for cell in self.grid.target_cells if cell not in taken]
        return choices[int(self.np_random.integers(len(choices)))]

    def _observations(self) -> dict[str, np.ndarray]:
        if self.observation == "global":
            state = self.state()
            return {agent: state.copy() for agent in self.agents}
        return {
            agent: np.array(
                (*self._cells[self._index[agent]], *self._packages[self._index[agent]]),
                dtype=np.int64,
            )
            for agent in self.agents
        }

    def _infos(
        self, refused: list[bool], snap_errors: np.ndarray, gaps: np.ndarray | None
    ) -> dict[str, dict[str, Any]]:
        infos = {}
        for agent in self.agents:
            i = self._index[agent]
            info = {
                "optimal_steps": self.grid.optimal_steps(self._cells[i], self._packages[i]),
                "refused": bool(refused[i]),
                "deliveries": int(self._deliveries[i]),
            }
            if self.physics:
                info["snap_error"] = float(snap_errors[i])
                info["min_gap"] = float(gaps[i]) if gaps is not None else float("inf")
            infos[agent] = info
        return infos

    def _ansi(self) -> str:
        board = [["#" if (r, c) in self.grid.shelves else "_" for c in range(self.grid.cols)]
                 for r in range(self.grid.rows)]  # fmt: skip
        for i, package in enumerate(self._packages):
            board[package[0]][package[1]] = chr(ord("a") + i % 26)
        for i, cell in enumerate(self._cells):
            board[cell[0]][cell[1]] = str(i % 10)
        return "\n".join(" ".join(row) for row in board)


def parallel_env(**kwargs: Any) -> WarehouseFleetEnv:
    """The fleet as a PettingZoo ``ParallelEnv`` (see :class:`WarehouseFleetEnv`)."""
    return WarehouseFleetEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The fleet as a PettingZoo AEC environment: robots act in turn, moves happen together."""
    return parallel_to_aec(parallel_env(**kwargs))
