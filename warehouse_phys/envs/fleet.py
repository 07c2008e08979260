"""A fleet of robots on one warehouse floor, as PettingZoo environments.

``warehouse_phys.envs.fleet.parallel_env(**kwargs)`` returns a :class:`WarehouseFleetEnv`
(a PettingZoo ``ParallelEnv``); ``warehouse_phys.envs.fleet.env(**kwargs)`` the same as
an AEC environment (PettingZoo's ``parallel_to_aec``, refusing a bad action at once).

Its length is one PettingZoo environment whose class docstring, its specification,
is a fifth of it; the rules it applies live in :mod:`warehouse_phys.rules`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer, fleet_ansi_frame
from warehouse_phys.envs import onehot
from warehouse_phys.physics import PhysicsConfig, check_controller, physics_config_from
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.rules.batched import step_rewards
from warehouse_phys.rules.distances import DistanceMaps
from warehouse_phys.rules.layouts import make_grid, suggested_time_limit
from warehouse_phys.rules.traffic import (
    FLEET_ACTIONS,
    WAIT,
    check_clearance,
    corner_follows_are_safe,
    granted_moves,
    neighbour_table,
)

OBSERVATIONS = ("local", "global", "neighbours", "onehot", "neighbours_onehot")
DELIVERY_MODES = ("park", "leave", "new_package")
START_MODES = ("auto", "layout", "random")
#: Most robots whose observation may be ``"global"``: each robot's copy of the state
#: holds 4 numbers per robot, so the observations grow with the square of the fleet.
MAX_GLOBAL_OBSERVATION_ROBOTS = 256
#: Most robots in the physics world (one pymunk space; a step of 1,024 random moves
#: takes a few milliseconds of chipmunk and of the closest-approach diagnostic).
MAX_PHYSICS_ROBOTS = 1024
#: Bits of the ``"neighbours"`` mask, in action order: a robot stands LEFT, DOWN, RIGHT, UP.
NEIGHBOUR_BITS = (1, 2, 4, 8)
_INTEGER_TYPES = frozenset({int, np.int64, np.int32, np.int16, np.int8, np.uint8,
                            np.uint16, np.uint32, np.uint64})  # fmt: skip


class WarehouseFleetEnv(ParallelEnv):
    """Robots on one warehouse floor, each delivering its own packages.

    ## Description
    ``num_robots`` robots share one floor (the default 4 x 5, any size, a preset,
    or a MovingAI ``.map`` file). All move at once; the traffic rule of
    :mod:`warehouse_phys.rules.traffic` decides which moves are granted (walls and
    shelves refuse a move; among robots heading for one cell the lowest-numbered
    goes; a robot heading for a cell whose occupant stays waits, so chains and
    rotations move together; swaps wait; corner follows only for robots small
    enough to pass). A step costs O(N) array operations: fleets of thousands of
    robots run on the grid twin. With ``physics=True`` every robot is a body in
    one pymunk space (:class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld`,
    shapes that collide with each other), each granted move is driven exactly as
    in the single physics environment and a waiting robot holds its cell's
    centre. A physical setting is accepted only if the robots' controller passes
    :func:`~warehouse_phys.physics.check_controller` and leaves room between
    every two robots in every situation the rule grants
    (:func:`~warehouse_phys.rules.traffic.check_clearance`: discs of diameter ``d``
    cells need ``1 - 2e >= d + 0.02``, where ``e`` is how far the controller
    carries a robot past its cell); anything else is refused with a
    ``ValueError`` that names the bound. For every accepted setting the tests
    prove that the bodies end on the grid twin's cells, and that no two discs
    ever come closer than their diameter minus the collision slop.

    ## Action Space
    ``Discrete(5)`` per robot: LEFT=0, DOWN=1, RIGHT=2, UP=3 (as the single
    environments) and WAIT=4 (:data:`warehouse_phys.rules.traffic.WAIT`). ``step``
    takes a dict with an action for every live robot; anything else raises
    ``ValueError``/``TypeError`` naming the robot and changes nothing.

    ## Observation Space
    - ``"local"`` (default): each robot sees its own
      ``[row, col, package_row, package_col]`` (``MultiDiscrete([R, C, R, C])``),
      so one Q-table of shape ``(R, C, R, C, 5)`` serves every robot.
    - ``"neighbours"``: the same four numbers and a mask of the adjacent cells on
      which a robot stands (LEFT=1, DOWN=2, RIGHT=4, UP=8, :data:`NEIGHBOUR_BITS`;
      parked robots count, robots that left the floor do not):
      ``MultiDiscrete([R, C, R, C, 16])``, a shared table ``(R, C, R, C, 16, 5)``.
    - ``"global"``: every robot sees every robot's four numbers, in robot order
      (``MultiDiscrete([R, C, R, C] * num_robots)``), as :meth:`state` returns;
      at most :data:`MAX_GLOBAL_OBSERVATION_ROBOTS` robots.
    - ``"onehot"``, for neural networks and SuperSuit: the ``"local"`` view one-hot
      encoded as in the single environments, ``Box(0, 1, (R + C + R + C,),
      float32)`` (1.0 at ``row``, ``R + col``, ``R + C + package_row`` and
      ``2R + C + package_col``).
    - ``"neighbours_onehot"``: ``"onehot"`` followed by the ``"neighbours"`` mask
      as 4 bits of 0.0 or 1.0 in action order (a robot stands LEFT, DOWN, RIGHT,
      UP), ``Box(0, 1, (R + C + R + C + 4,), float32)``.

    ## Starting State
    ``starts="layout"``: on a floor with several ``S`` cells robot ``i`` stands
    on the ``i``-th in reading order; otherwise robot 0 on the floor's start and
    the others on the next cells a robot can reach in reading order (on a plain
    floor: the first cells of row 0, then of row 1, ...). ``starts="random"``:
    at every reset the robots stand on distinct cells drawn uniformly, with the
    environment's generator, from the cells reachable from the floor's start.
    ``starts="auto"`` (default) is ``"random"`` on floors that mark no start
    (MovingAI maps, the ``warehouse`` preset) and ``"layout"`` elsewhere. Each
    robot's package is drawn uniformly from the floor's package cells, never on
    a robot's cell or another robot's package. A floor without room for the
    fleet is refused with a ``ValueError`` that gives the counts.

    ## Rewards
    1.0 to a robot on the step it reaches its package, else 0.0.

    ## Episode End
    ``on_delivery`` decides what a robot does once it reaches its package:
    ``"park"`` (default): it terminates and stays there, an obstacle;
    ``"leave"``: it terminates and leaves the floor (POGEMA's one-shot mode);
    ``"new_package"``: it gets a new package at once and never terminates
    (lifelong; ``lifelong=True`` is shorthand for it). The episode ends when
    every robot has terminated or at ``max_cycles`` steps (truncation).

    ``infos[robot]`` holds ``optimal_steps`` (to its own package, ignoring the
    other robots), ``refused`` (whether traffic turned its move into a wait),
    ``deliveries`` (packages delivered this episode) and, in the physics world,
    ``snap_error`` and ``min_gap``: the smallest distance during the step between
    its disc and the disc of a robot that started the step within reach, at most
    :data:`~warehouse_phys.physics.batched.GAP_REACH` rows and columns away (the
    only robots it can touch) [cells]; negative: the discs overlapped; ``inf``:
    no robot within reach. Robots out of reach stay farther apart than
    ``sqrt(2) (1 - e) - d`` and are not measured. It costs a read of every body
    after each physics step and a comparison of the robots within reach;
    ``track_gaps=False`` leaves both out, and ``min_gap`` with them.

    Planners and evaluators read the fleet through read-only arrays:
    :attr:`robot_cells` and :attr:`package_cells` ``(N, 2)``, :attr:`parked`,
    :attr:`on_floor`, :attr:`deliveries` ``(N,)``, :attr:`steps`, and
    :attr:`distances`, the floor's shortest-path distances to packages (one
    :class:`~warehouse_phys.rules.distances.DistanceMaps`, built as packages appear).

    ## Arguments
    - ``num_robots`` (int, default 2): at least 1, at most what the floor has
      start and package cells for (at most :data:`MAX_PHYSICS_ROBOTS` in the
      physics world).
    - ``physics`` (bool, default False): whether the robots are bodies in a
      physics world; the attribute :attr:`physics` is then its
      :class:`~warehouse_phys.physics.PhysicsConfig` (``None`` in the grid twin),
      as in every environment. The physical keywords of
      :class:`~warehouse_phys.envs.WarehousePhysicsEnv` (``robot_radius`` ...)
      also decide for the grid twin whether corner follows are granted.
    - ``grid_rows``, ``grid_cols``, ``layout``: the floor, as in the single
      environments (``layout`` also takes a path to a MovingAI ``.map`` file).
    - ``on_delivery`` (``"park"``, ``"leave"``, ``"new_package"``), ``lifelong``
      (bool), ``starts`` (``"auto"``, ``"layout"``, ``"random"``), ``max_cycles``
      (int; default :func:`~warehouse_phys.rules.layouts.suggested_time_limit` of the
      floor, the single environments' limit), ``observation`` (``"local"``,
      ``"neighbours"``, ``"global"``, ``"onehot"``, ``"neighbours_onehot"``),
      ``render_mode`` (``None``; ``"rgb_array"``:
      every robot in a ring of its own colour, its package framed in the same
      colour; ``"ansi"``: robots as digits, packages as letters), ``cell_px``.
      :meth:`move_frames` gives the physics world's motion during the last step,
      one frame per physics step.
    - ``track_gaps`` (bool, default True): whether the physics world measures
      ``min_gap``.

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
        on_delivery: str | None = None,
        starts: str = "auto",
        track_gaps: bool = True,
        **physical: float,
    ) -> None:
        if isinstance(num_robots, bool) or not isinstance(num_robots, (int, np.integer)):
            raise TypeError(f"num_robots must be an integer, got {num_robots!r}")
        if num_robots < 1:
            raise ValueError(f"num_robots must be at least 1, got {num_robots}")
        flags = (("physics", physics), ("lifelong", lifelong), ("track_gaps", track_gaps))
        for name, flag in flags:
            if not isinstance(flag, bool):
                raise TypeError(f"{name} must be a bool, got {flag!r}")
        for name, value, choices in (
            ("observation", observation, OBSERVATIONS),
            ("on_delivery", "park" if on_delivery is None else on_delivery, DELIVERY_MODES),
            ("starts", starts, START_MODES),
        ):
            if not isinstance(value, str) or value not in choices:
                raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")
        if lifelong and on_delivery not in (None, "new_package"):
            raise ValueError(
                f"lifelong=True means on_delivery='new_package'; got on_delivery={on_delivery!r}"
            )
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if physics and num_robots > MAX_PHYSICS_ROBOTS:
            raise ValueError(
                f"the physics world takes at most {MAX_PHYSICS_ROBOTS} robots, got {num_robots}"
            )
        if physics and on_delivery == "leave":
            raise ValueError(
                "on_delivery='leave' is for the grid twin: in the physics world a robot's "
                "body cannot leave the floor yet; use 'park' or 'new_package'"
            )
        if observation == "global" and num_robots > MAX_GLOBAL_OBSERVATION_ROBOTS:
            raise ValueError(
                f"observation='global' takes at most {MAX_GLOBAL_OBSERVATION_ROBOTS} robots "
                f"(each robot's copy holds 4 numbers per robot: {num_robots} robots would need "
                f"{32 * num_robots**2 / 2**20:,.0f} MiB a step); use 'local' or 'neighbours'"
            )
        self.grid = make_grid(grid_rows, grid_cols, layout)
        self.num_robots = int(num_robots)
        self._track_gaps = track_gaps
        self.on_delivery = "new_package" if lifelong else on_delivery or "park"
        self.observation = observation
        self.render_mode = render_mode
        if max_cycles is None:
            max_cycles = suggested_time_limit(self.grid)
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, (int, np.integer)):
            raise TypeError(f"max_cycles must be an integer, got {max_cycles!r}")
        if max_cycles < 1:
            raise ValueError(f"max_cycles must be at least 1, got {max_cycles}")
        self.max_cycles = int(max_cycles)
        # The physical parameters are checked in both twins: the robots' size decides
        # whether the rule grants corner follows.
        config = physics_config_from(physical)
        if physics:  # the controller keeps one robot's promises, and the fleet's robots apart
            check_clearance(config.robot_diameter, *check_controller(config))
        #: The physics world's parameters, as in every environment; ``None`` in the grid twin.
        self.physics: PhysicsConfig | None = config if physics else None
        #: Whether the traffic rule grants corner follows (robots small enough to pass).
        self.corner_follows = corner_follows_are_safe(config.robot_diameter)
        if starts == "auto":
            starts = "layout" if getattr(self.grid, "starts_marked", True) else "random"
        self.starts_mode = starts
        cols = self.grid.cols
        self._targets = np.array([r * cols + c for r, c in self.grid.target_cells], np.int64)
        self._reachable = np.array(sorted(r * cols + c for r, c in self.grid.reachable), np.int64)
        self._check_room()

        self.possible_agents = [f"robot_{i}" for i in range(self.num_robots)]
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        rows = self.grid.rows
        self._local_space = spaces.MultiDiscrete([rows, cols, rows, cols])
        self._neighbours_space = spaces.MultiDiscrete([rows, cols, rows, cols, 16])
        self._onehot_space = spaces.Box(0.0, 1.0, (2 * rows + 2 * cols,), np.float32)
        self._neighbours_onehot_space = spaces.Box(
            0.0, 1.0, (2 * rows + 2 * cols + len(NEIGHBOUR_BITS),), np.float32
        )
        self._action_space = spaces.Discrete(FLEET_ACTIONS)
        n = self.num_robots
        self.state_space = (
            spaces.MultiDiscrete([rows, cols, rows, cols] * n)
            if n <= MAX_GLOBAL_OBSERVATION_ROBOTS
            else None
        )

        self.np_random, _ = seeding.np_random(None)
        self._cells = np.zeros((n, 2), dtype=np.int64)  # and _here, as indices
        self._packages = np.zeros((n, 2), dtype=np.int64)  # and _package_index
        self._every_robot = _read_only(np.arange(n))
        self._parked = np.zeros(n, dtype=bool)
        self._on_floor = np.ones(n, dtype=bool)
        self._deliveries = np.zeros(n, dtype=np.int64)
        self._steps = 0
        self._distances: DistanceMaps | None = None
        self.world: BatchedPhysicsWorld | None = None
        self._renderer = WarehouseRenderer.for_grid(
            self.grid, cell_px=cell_px, render_fps=self.metadata["render_fps"]
        )
        if render_mode == "rgb_array":
            self._renderer.check_frame_size()

    # ------------------------------------------------------------ the state
    @property
    def _cells(self) -> np.ndarray:
        """Each robot's ``(row, col)``, kept with its index ``row * cols + col`` (``_here``)."""
        return self._cell_rows_cols

    @_cells.setter
    def _cells(self, cells: np.ndarray) -> None:
        self._cell_rows_cols = cells
        self._here = cells[:, 0] * self.grid.cols + cells[:, 1]

    @property
    def _packages(self) -> np.ndarray:
        """Each robot's package ``(row, col)``, kept with its index (``_package_index``);
        changed in place by :meth:`_draw_new_packages`, which updates both."""
        return self._package_rows_cols

    @_packages.setter
    def _packages(self, packages: np.ndarray) -> None:
        self._package_rows_cols = packages
        self._package_index = packages[:, 0] * self.grid.cols + packages[:, 1]

    # ------------------------------------------------------------ the public state
    @property
    def track_gaps(self) -> bool:
        """Whether a physics step measures ``min_gap`` (reading every body after each
        physics step; frames of the motion need the same reads). Fixed when built."""
        return self._track_gaps

    @property
    def lifelong(self) -> bool:
        """Whether a robot gets a new package on delivery (``on_delivery="new_package"``)."""
        return self.on_delivery == "new_package"

    @property
    def starts(self) -> list[tuple[int, int]]:
        """The start cells of ``starts="layout"`` (the robots' cells at every reset)."""
        return [tuple(cell) for cell in self._layout_starts().tolist()]

    @property
    def robot_cells(self) -> np.ndarray:
        """Each robot's ``(row, col)``, ``(N, 2)`` int64, read-only (a robot that left the
        floor keeps the cell it left from)."""
        return _read_only(self._cells)

    @property
    def package_cells(self) -> np.ndarray:
        """Each robot's package ``(row, col)``, ``(N, 2)`` int64, read-only."""
        return _read_only(self._packages)

    @property
    def parked(self) -> np.ndarray:
        """Which robots are parked on their delivered package (``on_delivery="park"``)."""
        return _read_only(self._parked)

    @property
    def on_floor(self) -> np.ndarray:
        """Which robots are on the floor (all but those that left, ``on_delivery="leave"``)."""
        return _read_only(self._on_floor)

    @property
    def deliveries(self) -> np.ndarray:
        """Packages each robot delivered this episode, ``(N,)`` int64, read-only."""
        return _read_only(self._deliveries)

    @property
    def steps(self) -> int:
        """Joint steps taken this episode."""
        return self._steps

    @property
    def distances(self) -> DistanceMaps:
        """Shortest-path distances on this floor to the packages (shared with planners)."""
        if self._distances is None:
            self._distances = DistanceMaps(self.grid)
        return self._distances

    def observation_space(self, agent: str) -> spaces.MultiDiscrete | spaces.Box:
        """The observation space of ``agent`` (the same object on every call)."""
        self._checked_agent(agent)
        return {
            "local": self._local_space,
            "neighbours": self._neighbours_space,
            "global": self.state_space,
            "onehot": self._onehot_space,
            "neighbours_onehot": self._neighbours_onehot_space,
        }[self.observation]

    def action_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(5)``: the four moves and WAIT (the same object on every call)."""
        self._checked_agent(agent)
        return self._action_space

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Every robot on a start cell with a new package; ``seed`` seeds the generator.

        ``options`` are accepted and ignored (PettingZoo's test suites pass some).
        """
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        rng = self.np_random
        n, cols = self.num_robots, self.grid.cols
        if self.starts_mode == "random":  # the packages first, then the starts off them
            packages = self._targets[rng.choice(len(self._targets), n, replace=False)]
            allowed = self._reachable[~np.isin(self._reachable, packages)]
            here = allowed[rng.choice(len(allowed), n, replace=False)]
        else:
            here = self._layout_starts_index
            allowed = self._targets[~np.isin(self._targets, here)]
            packages = allowed[rng.choice(len(allowed), n, replace=False)]
        self._cells = np.stack(np.divmod(here, cols), axis=1)
        self._packages = np.stack(np.divmod(packages, cols), axis=1)
        self.agents = list(self.possible_agents)
        self._parked[:] = False
        self._on_floor[:] = True
        self._deliveries[:] = 0
        self._steps = 0
        if self.physics and self.world is None:
            self.world = BatchedPhysicsWorld(
                self.grid, self.physics, self._cells, np.zeros(n, dtype=np.int64),
                record_path=self.track_gaps or self.render_mode == "rgb_array",
            )  # fmt: skip
        elif self.physics:  # every robot as newly built, in the same world
            self.world.restart(np.arange(n), self._cells)
        live = np.arange(n)
        refused = np.zeros(n, dtype=bool)
        return self._observations(live), self._infos(live, refused, None, None)

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        """Move every live robot by its action under the traffic rule."""
        if not self.agents:
            raise ValueError("the episode is over (no live robots): call reset()")
        live = self._live_indices()
        joint = self._checked_actions(actions, live)
        cols = self.grid.cols
        here = self._here
        if self.on_delivery != "leave" or self._on_floor.all():
            parked = None if self.on_delivery == "new_package" else self._parked  # none park
            moved, refused, bumped = granted_moves(
                self.grid, here, joint, parked, corner_follows=self.corner_follows
            )
        else:  # robots that left are no obstacles
            floor = self._on_floor
            moved, (refused, bumped) = here.copy(), np.zeros((2, self.num_robots), dtype=bool)
            moved[floor], refused[floor], bumped[floor] = granted_moves(
                self.grid, here[floor], joint[floor], self._parked[floor],
                corner_follows=self.corner_follows,
            )  # fmt: skip
        ends = np.empty((self.num_robots, 2), dtype=np.int64)
        np.divmod(moved, cols, out=(ends[:, 0], ends[:, 1]))
        snap_errors = gaps = None
        if self.physics:  # the granted moves and the bumps driven, the rest held
            body_cells, snap_errors = self.world.move_granted(joint, ends, bumped)
            ends = np.asarray(body_cells, dtype=np.int64).reshape(-1, 2)
            gaps = self.world.closest_gaps() if self.track_gaps else None
        self._cell_rows_cols = ends  # the cells, their indices set below
        self._steps += 1

        if self.physics:  # the cells read from the bodies (the same, as the tests prove)
            moved = ends[:, 0] * cols + ends[:, 1]
        self._here = moved
        arrived = moved == self._package_index
        if len(live) < self.num_robots:  # the parked and the gone deliver no more
            arrived &= np.isin(self._every_robot, live)
        delivered = arrived.nonzero()[0]
        if delivered.size:
            self._deliveries[delivered] += 1
            if self.on_delivery == "new_package":
                self._draw_new_packages(delivered)
            else:
                self._parked[delivered] = self.on_delivery == "park"
                self._on_floor[delivered] = self.on_delivery == "park"
        agents = self.agents
        arrived_live = arrived if len(live) == self.num_robots else arrived[live]
        rewards = dict(zip(agents, step_rewards(arrived_live).tolist(), strict=True))
        arrived_live = arrived_live.tolist()
        ends_robot = arrived_live if not self.lifelong else [False] * len(agents)
        terminations = dict(zip(agents, ends_robot, strict=True))
        truncated = self._steps >= self.max_cycles
        if truncated:
            truncations = {
                agent: not ended for agent, ended in zip(agents, ends_robot, strict=True)
            }
        else:
            truncations = dict.fromkeys(agents, False)
        observations = self._observations(live)
        infos = self._infos(live, refused, snap_errors, gaps)
        if truncated:
            self.agents = []
        elif not self.lifelong and delivered.size:
            self.agents = [agent for agent, ended in zip(agents, ends_robot, strict=True)
                           if not ended]  # fmt: skip
        return observations, rewards, terminations, truncations, infos

    def render(self) -> np.ndarray | str | None:
        """``"rgb_array"``: every robot in its colour with its package; ``"ansi"``: text."""
        if self.render_mode is None:
            return None
        if not self._steps and not self.agents:
            raise ValueError("call reset() before render()")
        if self.render_mode == "ansi":
            return fleet_ansi_frame(
                self.grid.rows, self.grid.cols, self._cells.tolist(), self._package_list(),
                self._on_floor.tolist(), self.grid.shelves,
            )  # fmt: skip
        positions = (
            self.world.positions().tolist() if self.world is not None else self._cells.tolist()
        )
        return self._renderer.fleet_rgb_array(
            positions, self._package_list(), delivered=self._parked.tolist()
        )

    def move_frames(self) -> list[np.ndarray]:
        """The frames of the last step's motion in the physics world, one per physics step
        (the last just before the snap), as ``(H, W, 3)`` uint8 arrays; needs no display.

        Raises:
            ValueError: in the grid twin, which has no motion between cells.
        """
        if self.world is None:
            raise ValueError("only the physics world (physics=True) has motion frames")
        if not self.world.record_path:
            raise ValueError(
                "this fleet does not record the motion: make it with render_mode='rgb_array' "
                "or track_gaps=True"
            )
        paths = self.world.last_paths  # (K, steps, 2)
        packages = self._package_list()
        return [
            self._renderer.fleet_rgb_array(paths[:, step].tolist(), packages)
            for step in range(paths.shape[1])
        ]

    def close(self) -> None:
        """Release the renderer's pygame resources."""
        self._renderer.close()

    def state(self) -> np.ndarray:
        """The global picture: every robot's ``[row, col, package_row, package_col]``."""
        return np.concatenate([self._cells, self._packages], axis=1).ravel()

    # ------------------------------------------------------------------ helpers
    def _check_room(self) -> None:
        """Refuse a fleet the floor has no start or package cells for, with the counts."""
        n = self.num_robots
        if self.starts_mode == "layout":
            self._layout_starts_index = self._layout_starts() @ np.array([self.grid.cols, 1])
        elif len(self._reachable) < 2 * n:
            raise ValueError(
                f"{n:,} robots need {2 * n:,} cells a robot can reach (random starts, off the "
                f"packages); this floor has {len(self._reachable):,}"
            )
        if self.lifelong:
            # A robot that delivers stands on a package cell, the others may too, and
            # their packages take n - 1 more: its new one needs one cell beyond.
            needed, room = 2 * n, len(self._targets)
            where = " (lifelong: one for every robot and every package)"
        elif self.starts_mode == "layout":
            needed = n
            room = int((~np.isin(self._targets, self._layout_starts_index)).sum())
            where = " away from the starts"
        else:  # random starts stand off the packages
            needed, room, where = n, len(self._targets), ""
        if room < needed:
            raise ValueError(
                f"{n:,} robots need {needed:,} package cells{where}; this floor has {room:,}"
            )

    def _layout_starts(self) -> np.ndarray:
        """A fleet layout's ``S`` cells; else the floor's start, then the other cells robots
        can reach in reading order; ``(N, 2)``."""
        n = self.num_robots
        marked = self.grid.starts
        if len(marked) > 1:
            if len(marked) < n:
                raise ValueError(
                    f"{n} robots need {n} start cells; the layout marks {len(marked)} ('S')"
                )
            return np.array(marked[:n], dtype=np.int64).reshape(n, 2)
        start = self.grid.start[0] * self.grid.cols + self.grid.start[1]
        others = self._reachable[self._reachable != start]
        if len(others) + 1 < n:
            raise ValueError(
                f"{n} robots need {n} start cells; this floor has {len(others) + 1} cells a "
                "robot can reach"
            )
        index = np.concatenate([[start], others[: n - 1]])
        return np.stack(np.divmod(index, self.grid.cols), axis=1)

    def _draw_new_packages(self, robots: np.ndarray) -> None:
        """New packages for ``robots``, each uniform over the package cells on no robot and
        no other robot's package (rejection sampling, then an exact draw if it keeps missing).

        The robots draw in order, each one cell at a time. All first draws are made at
        once; when they all land on free, distinct cells (the usual case) that is what
        drawing in turn gives, else the generator is put back and the robots draw in turn.
        """
        if not robots.size:
            return
        cols = self.grid.cols
        taken = np.zeros(self.grid.rows * cols, dtype=bool)
        taken[self._here] = True
        keep = np.ones(self.num_robots, dtype=bool)
        keep[robots] = False
        taken[self._package_index[keep]] = True
        rng = self.np_random
        before = rng.bit_generator.state
        cells = self._targets[rng.integers(len(self._targets), size=robots.size)]
        if not taken[cells].any() and (robots.size == 1 or np.unique(cells).size == robots.size):
            self._packages[robots, 0], self._packages[robots, 1] = np.divmod(cells, cols)
            self._package_index[robots] = cells
            return
        rng.bit_generator.state = before
        for robot in robots.tolist():
            for _ in range(8):
                cell = self._targets[rng.integers(len(self._targets))]
                if not taken[cell]:
                    break
            else:
                free = self._targets[~taken[self._targets]]
                cell = free[rng.integers(len(free))]
            taken[cell] = True
            self._packages[robot] = divmod(int(cell), cols)
            self._package_index[robot] = cell

    def _live_indices(self) -> np.ndarray:
        if len(self.agents) == self.num_robots:
            return self._every_robot
        return np.fromiter(map(self._index.__getitem__, self.agents), np.int64, len(self.agents))

    def _checked_actions(self, actions: object, live: np.ndarray) -> np.ndarray:
        """The joint action (WAIT for robots not live), or an error naming the robot."""
        if not isinstance(actions, dict):
            raise TypeError(
                f"actions must be a dict of robot to action, got {type(actions).__name__}"
            )
        # The usual case first: every live robot, in order, with a plain integer.
        if list(actions) == self.agents and set(map(type, actions.values())) <= _INTEGER_TYPES:
            values = np.fromiter(actions.values(), np.int64, len(actions))
            if not np.count_nonzero(values.view(np.uint64) >= FLEET_ACTIONS):  # negatives: huge
                if len(values) == self.num_robots:
                    return values
                joint = np.full(self.num_robots, WAIT, dtype=np.int64)
                joint[live] = values
                return joint
        joint = np.full(self.num_robots, WAIT, dtype=np.int64)
        unknown = [agent for agent in actions if agent not in self.agents]
        if unknown:
            raise ValueError(
                f"actions for robots that are not live: {unknown}; live: {self.agents}"
            )
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {missing}")
        for agent, action in actions.items():
            joint[self._index[agent]] = self._checked_action(agent, action)
        return joint

    def _checked_action(self, agent: str, action: object) -> int:
        """``action`` as an int 0..4, or a ``TypeError``/``ValueError`` naming ``agent``."""
        is_integer = (
            isinstance(action, (int, np.integer)) and not isinstance(action, np.timedelta64)
        ) or (isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu")
        if isinstance(action, (bool, np.bool_)) or not is_integer:
            raise TypeError(f"{agent}'s action must be an integer 0..4, got {action!r}")
        if not 0 <= int(action) < FLEET_ACTIONS:
            raise ValueError(f"{agent}'s action must be 0..4 (4 is WAIT), got {action!r}")
        return int(action)

    def _checked_agent(self, agent: str) -> None:
        if agent not in self._index:
            raise ValueError(f"unknown robot {agent!r}; the robots are {self.possible_agents}")

    def _observations(self, live: np.ndarray) -> dict[str, np.ndarray]:
        if self.observation == "global":
            state = self.state()
            return {agent: state.copy() for agent in self.agents}
        if len(live) == self.num_robots:
            columns = [self._cells, self._packages]
        else:
            columns = [self._cells[live], self._packages[live]]
        if self.observation == "neighbours":
            columns.append(self._neighbour_masks(live)[:, None])
        rows = np.concatenate(columns, axis=1)
        if self.observation in ("onehot", "neighbours_onehot"):
            rows = onehot(rows, self.grid.rows, self.grid.cols)
            if self.observation == "neighbours_onehot":
                bits = np.arange(len(NEIGHBOUR_BITS))
                masks = (self._neighbour_masks(live)[:, None] >> bits) & 1
                rows = np.concatenate([rows, masks.astype(np.float32)], axis=1)
        return dict(zip(self.agents, rows, strict=True))

    def _neighbour_masks(self, robots: np.ndarray) -> np.ndarray:
        """The :data:`NEIGHBOUR_BITS` mask of adjacent cells holding a robot on the floor."""
        cols = self.grid.cols
        occupied = np.zeros(self.grid.rows * cols + 1, dtype=bool)
        on = self._cells[self._on_floor]
        occupied[on[:, 0] * cols + on[:, 1]] = True
        here = self._cells[robots, 0] * cols + self._cells[robots, 1]
        table = neighbour_table(self.grid)
        mask = np.zeros(len(robots), dtype=np.int64)
        for action, bit in enumerate(NEIGHBOUR_BITS):
            there = table[here, action]
            mask |= np.where((there != here) & occupied[there], bit, 0)
        return mask

    def _infos(
        self,
        live: np.ndarray,
        refused: np.ndarray,
        snap_errors: np.ndarray | None,
        gaps: np.ndarray | None,
    ) -> dict[str, dict[str, Any]]:
        all_live = len(live) == self.num_robots  # no copies in the usual case
        if not self.grid.shelves:  # an open floor: Manhattan distances
            cells = self._cells if all_live else self._cells[live]
            packages = self._packages if all_live else self._packages[live]
            apart = np.abs(cells - packages)
            optimal = apart[:, 0] + apart[:, 1]
        elif all_live:
            optimal = self.distances.lookup(self._here, self._package_index)
        else:
            optimal = self.distances.lookup(self._here[live], self._package_index[live])
        if not all_live:
            refused, deliveries = refused[live], self._deliveries[live]
        else:
            deliveries = self._deliveries
        columns = [optimal.tolist(), refused.tolist(), deliveries.tolist()]
        if not self.physics:
            return {
                agent: {"optimal_steps": o, "refused": r, "deliveries": d}
                for agent, o, r, d in zip(self.agents, *columns, strict=True)
            }
        if snap_errors is None:  # at a reset
            snap_errors, gaps = np.zeros(self.num_robots), np.full(self.num_robots, np.inf)
        columns.append(snap_errors[live].astype(float).tolist())
        if not self.track_gaps:
            return {
                agent: {"optimal_steps": o, "refused": r, "deliveries": d, "snap_error": s}
                for agent, o, r, d, s in zip(self.agents, *columns, strict=True)
            }
        columns.append(gaps[live].astype(float).tolist())
        return {
            agent: {"optimal_steps": o, "refused": r, "deliveries": d, "snap_error": s,
                    "min_gap": g}
            for agent, o, r, d, s, g in zip(self.agents, *columns, strict=True)
        }  # fmt: skip

    def _package_list(self) -> list[tuple[int, int]]:
        return [tuple(p) for p in self._packages.tolist()]


def _read_only(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view


class _FleetAEC(parallel_to_aec_wrapper):
    """PettingZoo's AEC form of the fleet, refusing a bad action when it is given (the
    joint step happens at the last robot's turn, too late to refuse it cleanly)."""

    def step(self, action: int | None) -> None:
        agent = self.agent_selection
        if not (self.terminations[agent] or self.truncations[agent]):
            action = self.env._checked_action(agent, action)
        super().step(action)


def parallel_env(**kwargs: Any) -> WarehouseFleetEnv:
    """The fleet as a PettingZoo ``ParallelEnv`` (see :class:`WarehouseFleetEnv`)."""
    return WarehouseFleetEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The fleet as a PettingZoo AEC environment: robots act in turn, moves happen together."""
    return OrderEnforcingWrapper(_FleetAEC(parallel_env(**kwargs)))
