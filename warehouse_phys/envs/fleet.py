"""A fleet of robots on one warehouse floor, as PettingZoo environments.

``warehouse_phys.envs.fleet.parallel_env(**kwargs)`` returns a :class:`WarehouseFleetEnv`
(a PettingZoo ``ParallelEnv``); ``warehouse_phys.envs.fleet.env(**kwargs)`` the same as
an AEC environment (PettingZoo's ``parallel_to_aec``, refusing a bad action at once).

Its length is one PettingZoo environment whose class docstring, its specification,
is a fifth of it; the rules it applies live in :mod:`warehouse_phys.world`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer, fleet_ansi_frame
from warehouse_phys.envs.fleet_actions import FleetActions, number_text
from warehouse_phys.envs.fleet_observations import (
    MAX_GLOBAL_OBSERVATION_ROBOTS,
    NEIGHBOUR_BITS,
    OBSERVATIONS,
    FleetObservations,
    robot_infos,
)
from warehouse_phys.lorr.errands import ErrandList, errand_list
from warehouse_phys.lorr.instances import LorrInstance, as_instance
from warehouse_phys.lorr.scheduling import Scheduler
from warehouse_phys.physics import PhysicsConfig, check_controller, physics_config_from
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.world.batched import step_rewards
from warehouse_phys.world.grid import refuse_durations
from warehouse_phys.world.headings import MOVE_MODELS, TURN_ACTIONS, Heading, joint_grants
from warehouse_phys.world.layouts import make_grid, suggested_time_limit
from warehouse_phys.world.placement import (
    START_MODES,
    check_room,
    draw_new_packages,
    draw_placement,
    layout_starts,
    package_cells,
    reachable_cells,
)
from warehouse_phys.world.traffic import FLEET_ACTIONS, check_clearance, corner_follows_are_safe

__all__ = [
    "DELIVERY_MODES",
    "LORR_STEPS",
    "MAX_GLOBAL_OBSERVATION_ROBOTS",
    "MAX_PHYSICS_ROBOTS",
    "NEIGHBOUR_BITS",
    "OBSERVATIONS",
    "START_MODES",
    "WarehouseFleetEnv",
    "env",
    "parallel_env",
]

DELIVERY_MODES = ("park", "leave", "new_package")
#: Most robots in the physics world (one pymunk space; a step of 1,024 random moves
#: takes a few milliseconds of chipmunk and of the closest-approach diagnostic).
MAX_PHYSICS_ROBOTS = 1024
#: An instance fleet's ``max_cycles`` by default: the competition's 5,000 steps.
LORR_STEPS = 5000


class WarehouseFleetEnv(ParallelEnv):
    """Robots on one warehouse floor, each delivering its own packages or a task list's errands.

    ## Description
    ``num_robots`` robots share one floor (the default 4 x 5, any size, a preset,
    or a MovingAI ``.map`` file). All move at once; the traffic rule of
    :mod:`warehouse_phys.world.traffic` decides which moves are granted (walls and
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
    (:func:`~warehouse_phys.world.traffic.check_clearance`: discs of diameter ``d``
    cells need ``1 - 2e >= d + 0.02``, where ``e`` is how far the controller
    carries a robot past its cell); anything else is refused with a
    ``ValueError`` that names the bound. For every accepted setting the tests
    prove that the bodies end on the grid twin's cells, and that no two discs
    ever come closer than their diameter minus the collision slop.

    With ``moves="rotate"`` the robots are the League of Robot Runners' turning
    robots (:mod:`warehouse_phys.world.headings`): each faces east, south, west or
    north, and turns in place or drives forward; in the physics world the body turns
    through the physics (its angle is the heading, snapped like its position). With
    ``instance=`` the fleet is a League of Robot Runners problem
    (:mod:`warehouse_phys.lorr.instances`): its floor, its robots' starts and its
    task list, handed out as the competition does (:mod:`warehouse_phys.lorr.errands`).

    ## Action Space
    ``Discrete(5)`` per robot: LEFT=0, DOWN=1, RIGHT=2, UP=3 (as the single
    environments) and WAIT=4 (:data:`warehouse_phys.world.traffic.WAIT`). Turning
    robots: ``Discrete(4)``, FORWARD=0, CLOCKWISE=1, COUNTERCLOCKWISE=2, WAIT=3
    (:class:`~warehouse_phys.world.headings.TurnAction`, the competition's order).
    ``step`` takes a dict with an action for every live robot; anything else raises
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

    Turning robots see their heading (0..3) after their package in every kind
    (``"local"``: ``MultiDiscrete([R, C, R, C, 4])``; one-hot: 4 more places
    before the mask). In an instance fleet a robot's package is its next errand,
    and a robot without one (every task handed out) sees its own cell there.

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
    fleet is refused with a ``ValueError`` that gives the counts. Placement rules:
    :mod:`warehouse_phys.world.placement`. Turning robots face east. An instance
    fleet starts where its instance says, and its first errands are handed out.

    ## Rewards
    1.0 to a robot on the step it reaches its package (an instance fleet: an errand),
    else 0.0.

    ## Episode End
    ``on_delivery`` decides what a robot does once it reaches its package:
    ``"park"`` (default): it terminates and stays there, an obstacle;
    ``"leave"``: it terminates and leaves the floor (POGEMA's one-shot mode);
    ``"new_package"``: it gets a new package at once and never terminates
    (lifelong; ``lifelong=True`` is shorthand for it). The episode ends when
    every robot has terminated or at ``max_cycles`` steps (truncation). An instance
    fleet is lifelong: its robots take the errands of the list.

    ``infos[robot]`` holds ``optimal_steps`` (to its own package, ignoring the other
    robots and turns; an upper bound beyond the distance maps' room), ``refused``
    (whether traffic made its move a wait), ``deliveries`` (this episode's packages or errands),
    ``tasks`` in an instance fleet (tasks finished) and, in the physics world,
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
    :attr:`on_floor`, :attr:`deliveries` ``(N,)``, :attr:`robot_headings` (turning
    robots), :attr:`steps`, :attr:`distances`, the floor's shortest-path distances
    to packages (one :class:`~warehouse_phys.planners.distances.DistanceMaps`, built as
    packages appear; to bound its memory, set ``env.distances = DistanceMaps(env.grid,
    max_bytes=...)`` before the first reset), and an instance fleet's :attr:`errands`
    (:class:`~warehouse_phys.lorr.errands.ErrandList`: errands and tasks finished).

    ## Arguments
    - ``num_robots`` (int, default 2; an instance's ``teamSize``): at least 1, at
      most what the floor has start and package cells for (at most
      :data:`MAX_PHYSICS_ROBOTS` in the physics world).
    - ``physics`` (bool, default False): whether the robots are bodies in a
      physics world; the attribute :attr:`physics` is then its
      :class:`~warehouse_phys.physics.PhysicsConfig` (``None`` in the grid twin),
      as in every environment. The physical keywords of
      :class:`~warehouse_phys.envs.WarehousePhysicsEnv` (``robot_radius`` ...)
      also decide for the grid twin whether corner follows are granted.
    - ``moves`` (``"grid"``, default: four directions; ``"rotate"``: turning robots).
    - ``instance`` (a :class:`~warehouse_phys.lorr.instances.LorrInstance` or the path
      of its JSON file): the floor, starts and errands of a League of Robot Runners
      problem; then ``grid_rows``, ``grid_cols``, ``layout`` and ``starts`` are not
      given, ``max_cycles`` defaults to :data:`LORR_STEPS`; ``scheduler`` (a
      :data:`~warehouse_phys.lorr.scheduling.Scheduler`, for 2024 and later
      instances; default the nearest pairing) and ``record_errands`` (bool: keep
      the events the competition's output file lists).
    - ``grid_rows``, ``grid_cols``, ``layout``: the floor, as in the single
      environments (``layout`` also takes a path to a MovingAI ``.map`` file).
    - ``on_delivery`` (``"park"``, ``"leave"``, ``"new_package"``), ``lifelong``
      (bool), ``starts`` (``"auto"``, ``"layout"``, ``"random"``), ``max_cycles``
      (int; default :func:`~warehouse_phys.world.layouts.suggested_time_limit` of the
      floor, the single environments' limit), ``observation`` (``"local"``,
      ``"neighbours"``, ``"global"``, ``"onehot"``, ``"neighbours_onehot"``),
      ``render_mode`` (``None``; ``"rgb_array"``:
      every robot in a ring of its own colour, its package framed in the same
      colour, a turning robot's heading as a pointer; ``"ansi"``: robots as digits,
      a turning robot's heading after it as ``> v < ^``, packages as letters),
      ``cell_px``.
      :meth:`move_frames` gives the physics world's motion during the last step,
      one frame per physics step.
    - ``track_gaps`` (bool, default True): whether the physics world measures
      ``min_gap``.

    ## Version History
    - v0: first version; turning robots and instances added without changing what
      the four-direction fleet does.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - PettingZoo reads this class attribute
        "name": "warehouse_fleet_v0",
        "render_modes": ["rgb_array", "ansi"],
        "render_fps": 4,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        num_robots: int | None = None,
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
        moves: str = "grid",
        instance: LorrInstance | str | os.PathLike[str] | None = None,
        scheduler: Scheduler | None = None,
        record_errands: bool = False,
        **physical: float,
    ) -> None:
        flags = (("physics", physics), ("lifelong", lifelong), ("track_gaps", track_gaps),
                 ("record_errands", record_errands))  # fmt: skip
        for name, flag in flags:
            if not isinstance(flag, bool):
                raise TypeError(f"{name} must be a bool, got {flag!r}")
        for name, value, choices in (
            ("observation", observation, OBSERVATIONS),
            ("on_delivery", "park" if on_delivery is None else on_delivery, DELIVERY_MODES),
            ("starts", starts, START_MODES),
            ("moves", moves, MOVE_MODELS),
        ):
            if not isinstance(value, str) or value not in choices:
                raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")
        floor = {"grid_rows": grid_rows, "grid_cols": grid_cols, "layout": layout}
        self.instance = _instance_of(instance, floor, starts, scheduler)
        if self.instance is not None:
            if on_delivery not in (None, "new_package"):
                raise ValueError(
                    f"an instance fleet is lifelong (its robots take the task list's errands); "
                    f"got on_delivery={on_delivery!r}"
                )
            lifelong = True
            num_robots = self.instance.team_size if num_robots is None else num_robots
        num_robots = 2 if num_robots is None else num_robots
        refuse_durations(num_robots=num_robots, max_cycles=max_cycles)
        if isinstance(num_robots, bool) or not isinstance(num_robots, (int, np.integer)):
            raise TypeError(f"num_robots must be an integer, got {num_robots!r}")
        if num_robots < 1:
            raise ValueError(f"num_robots must be at least 1, got {number_text(num_robots)}")
        if self.instance is not None and num_robots != self.instance.team_size:
            raise ValueError(
                f"num_robots={num_robots} but the instance {self.instance.name} has teamSize "
                f"{self.instance.team_size}; leave num_robots out"
            )
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
                f"(each robot's copy holds 4 numbers per robot: {num_robots:,} robots would need "
                f"{32 * int(num_robots) ** 2 / 2**20:,.0f} MiB a step); use 'local' or "
                "'neighbours'"
            )
        self.grid = (
            make_grid(grid_rows, grid_cols, layout) if self.instance is None else self.instance.grid
        )
        self.num_robots = int(num_robots)
        self._track_gaps = track_gaps
        self.on_delivery = "new_package" if lifelong else on_delivery or "park"
        self.observation = observation
        self.render_mode = render_mode
        #: The move model: ``"grid"`` (four directions) or ``"rotate"`` (turning robots).
        self.moves = moves
        if max_cycles is None:
            max_cycles = (
                LORR_STEPS if self.instance is not None else suggested_time_limit(self.grid)
            )
        if isinstance(max_cycles, bool) or not isinstance(max_cycles, (int, np.integer)):
            raise TypeError(f"max_cycles must be an integer, got {max_cycles!r}")
        if max_cycles < 1:
            raise ValueError(f"max_cycles must be at least 1, got {number_text(max_cycles)}")
        self.max_cycles = int(max_cycles)
        # The physical parameters are checked in both twins: the robots' size decides
        # whether the rule grants corner follows.
        config = physics_config_from(physical)
        if physics:  # the controller keeps one robot's promises, and the fleet's robots apart
            check_clearance(config.robot_diameter, *check_controller(config, turning=self.turning))
        #: The physics world's parameters, as in every environment; ``None`` in the grid twin.
        self.physics: PhysicsConfig | None = config if physics else None
        #: Whether the traffic rule grants corner follows (robots small enough to pass).
        self.corner_follows = corner_follows_are_safe(config.robot_diameter)
        self._errands: ErrandList | None = None
        if self.instance is not None:
            starts = "layout"
            self._errands = errand_list(self.instance, scheduler=scheduler, record=record_errands)
        elif starts == "auto":
            starts = "layout" if getattr(self.grid, "starts_marked", True) else "random"
        self.starts_mode = starts
        self._targets = package_cells(self.grid)
        self._reachable = reachable_cells(self.grid)
        self._layout_starts_index = None
        if self.instance is not None:
            self._layout_starts_index = self.instance.starts
        elif starts == "layout":
            self._layout_starts_index = layout_starts(self.grid, self.num_robots, self._reachable)
        if self.instance is None:
            check_room(self.num_robots, starts, self.lifelong, self._targets, self._reachable,
                       self._layout_starts_index)  # fmt: skip

        self.possible_agents = [f"robot_{i}" for i in range(self.num_robots)]
        self.agents: list[str] = []
        self._index = {agent: i for i, agent in enumerate(self.possible_agents)}
        n = self.num_robots
        self._observer = FleetObservations(observation, self.grid, n, turning=self.turning)
        self.state_space = self._observer.state_space
        count = TURN_ACTIONS if self.turning else FLEET_ACTIONS
        self._actions = FleetActions(n, count, self._index)
        self._action_space = spaces.Discrete(count)

        self.np_random, _ = seeding.np_random(None)
        self._cells = np.zeros((n, 2), dtype=np.int64)  # and _here, as indices
        self._packages = np.zeros((n, 2), dtype=np.int64)  # and _package_index
        self._headings = np.zeros(n, dtype=np.int64) if self.turning else None
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
    def turning(self) -> bool:
        """Whether the robots turn and drive forward (``moves="rotate"``)."""
        return self.moves == "rotate"

    @property
    def starts(self) -> list[tuple[int, int]]:
        """The start cells of ``starts="layout"`` (the robots' cells at every reset)."""
        if self._layout_starts_index is None:
            return []
        return [divmod(int(cell), self.grid.cols) for cell in self._layout_starts_index]

    @property
    def robot_cells(self) -> np.ndarray:
        """Each robot's ``(row, col)``, ``(N, 2)`` int64, read-only (a robot that left the
        floor keeps the cell it left from)."""
        return _read_only(self._cells)

    @property
    def robot_headings(self) -> np.ndarray | None:
        """Each turning robot's heading (:class:`~warehouse_phys.world.headings.Heading`),
        ``(N,)`` int64, read-only; ``None`` for robots that do not turn."""
        return None if self._headings is None else _read_only(self._headings)

    @property
    def package_cells(self) -> np.ndarray:
        """Each robot's package ``(row, col)``, ``(N, 2)`` int64, read-only (an instance
        fleet: its next errand; its own cell for a robot without one)."""
        return _read_only(self._packages)

    @property
    def errands(self) -> ErrandList | None:
        """An instance fleet's errand list (errands and tasks finished, events);
        ``None`` for a fleet that draws its packages."""
        return self._errands

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
        """Packages each robot delivered (an instance fleet: errands it finished) this
        episode, ``(N,)`` int64, read-only."""
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

    @distances.setter
    def distances(self, maps: DistanceMaps) -> None:
        if not isinstance(maps, DistanceMaps) or maps.grid is not self.grid:
            raise ValueError("distances must be a DistanceMaps of this fleet's grid")
        self._distances = maps

    def observation_space(self, agent: str) -> spaces.MultiDiscrete | spaces.Box:
        """The observation space of ``agent`` (the same object on every call)."""
        self._checked_agent(agent)
        return self._observer.space

    def action_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(5)``: the four moves and WAIT; turning robots ``Discrete(4)``:
        forward, the two turns and WAIT (the same object on every call)."""
        self._checked_agent(agent)
        return self._action_space

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Every robot on a start cell with a new package (an instance fleet: its first
        errand); ``seed`` seeds the generator.

        ``options`` are accepted and ignored (PettingZoo's test suites pass some).
        """
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        n, cols = self.num_robots, self.grid.cols
        if self._errands is not None:
            here = self._layout_starts_index
            self._errands.reset(here)
            packages = np.where(self._errands.goals >= 0, self._errands.goals, here)
        else:
            here, packages = draw_placement(self.np_random, n, self._targets, self._reachable,
                                            self._layout_starts_index)  # fmt: skip
        self._cells = np.stack(np.divmod(here, cols), axis=1)
        self._packages = np.stack(np.divmod(packages, cols), axis=1)
        if self._headings is not None:
            self._headings[:] = Heading.EAST
        self.agents = list(self.possible_agents)
        self._parked[:] = False
        self._on_floor[:] = True
        self._deliveries[:] = 0
        self._steps = 0
        if self.physics and self.world is None:
            self.world = BatchedPhysicsWorld(
                self.grid, self.physics, self._cells, np.zeros(n, dtype=np.int64),
                record_path=self.track_gaps or self.render_mode == "rgb_array",
                headings=self._headings,
            )  # fmt: skip
        elif self.physics:  # every robot as newly built, in the same world
            self.world.restart(np.arange(n), self._cells, self._headings)
        live = np.arange(n)
        refused = np.zeros(n, dtype=bool)
        return self._observations(live), self._infos(live, refused, None, None)

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        """Move every live robot by its action under the traffic rule."""
        if not self.agents:
            raise ValueError("the episode is over (no live robots): call reset()")
        live = self._live_indices()
        joint = self._actions.joint(actions, self.agents, live)
        floor = None if self.on_delivery != "leave" or self._on_floor.all() else self._on_floor
        moved, refused, bumped, headings = joint_grants(
            self.grid, self._here, joint, self._headings,
            parked=None if self.lifelong else self._parked, on_floor=floor,
            corner_follows=self.corner_follows,
        )  # fmt: skip
        cols = self.grid.cols
        ends = np.empty((self.num_robots, 2), dtype=np.int64)
        np.divmod(moved, cols, out=(ends[:, 0], ends[:, 1]))
        snap_errors = gaps = None
        if headings is not None:
            self._headings = headings
        if self.physics:  # the granted moves and the bumps driven, the rest held
            if self.turning:  # the headings read from the bodies too
                body_cells, self._headings, snap_errors = self.world.move_turning(
                    ends, headings, bumped
                )
            else:
                body_cells, snap_errors = self.world.move_granted(joint, ends, bumped)
            ends = np.asarray(body_cells, dtype=np.int64).reshape(-1, 2)
            gaps = self.world.closest_gaps() if self.track_gaps else None
        self._cell_rows_cols = ends  # the cells, their indices set below
        self._steps += 1

        if self.physics:  # the cells read from the bodies (the same, as the tests prove)
            moved = ends[:, 0] * cols + ends[:, 1]
        self._here = moved
        arrived = moved == self._package_index
        if self._errands is not None:
            arrived &= self._errands.goals >= 0
        elif len(live) < self.num_robots:  # the parked and the gone deliver no more
            arrived &= np.isin(self._every_robot, live)
        delivered = arrived.nonzero()[0]
        if self._errands is not None:
            self._deliveries[delivered] += 1
            self._errands.step(delivered, moved)
            goals = self._errands.goals
            self._packages = np.stack(np.divmod(np.where(goals >= 0, goals, moved), cols), axis=1)
        elif delivered.size:
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
        headings = None if self._headings is None else self._headings.tolist()
        if self.render_mode == "ansi":
            return fleet_ansi_frame(
                self.grid.rows, self.grid.cols, self._cells.tolist(), self._package_list(),
                self._on_floor.tolist(), self.grid.shelves, headings=headings,
            )  # fmt: skip
        if self.world is not None:
            positions = self.world.positions().tolist()
            headings = None if self._headings is None else self.world.orientations().tolist()
        else:
            positions = self._cells.tolist()
        return self._renderer.fleet_rgb_array(
            positions, self._package_list(), delivered=self._parked.tolist(), headings=headings
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
        turns = self.world.last_orientations if self.turning else None  # (K, steps)
        packages = self._package_list()
        return [
            self._renderer.fleet_rgb_array(
                paths[:, step].tolist(), packages,
                headings=None if turns is None else turns[:, step].tolist(),
            )
            for step in range(paths.shape[1])
        ]  # fmt: skip

    def close(self) -> None:
        """Release the renderer's pygame resources."""
        self._renderer.close()

    def state(self) -> np.ndarray:
        """The global picture: every robot's ``[row, col, package_row, package_col]`` (and
        heading, for turning robots)."""
        return self._observer.state(self._cells, self._packages, self._headings)

    # ------------------------------------------------------------------ helpers
    def _draw_new_packages(self, robots: np.ndarray) -> None:
        """New packages for ``robots``, as
        :func:`~warehouse_phys.world.placement.draw_new_packages` draws them."""
        if not robots.size:
            return
        cells = draw_new_packages(self.np_random, self._targets, self.grid.rows * self.grid.cols,
                                  self._here, self._package_index, robots)  # fmt: skip
        self._packages[robots, 0], self._packages[robots, 1] = np.divmod(cells, self.grid.cols)
        self._package_index[robots] = cells

    def _live_indices(self) -> np.ndarray:
        if len(self.agents) == self.num_robots:
            return self._every_robot
        return np.fromiter(map(self._index.__getitem__, self.agents), np.int64, len(self.agents))

    def _checked_agent(self, agent: str) -> None:
        if agent not in self._index:
            raise ValueError(f"unknown robot {agent!r}; the robots are {self.possible_agents}")

    def _observations(self, live: np.ndarray) -> dict[str, np.ndarray]:
        return self._observer.observe(
            self.agents, None if len(live) == self.num_robots else live, self._cells,
            self._packages, self._headings, self._on_floor,
        )  # fmt: skip

    def _infos(
        self,
        live: np.ndarray,
        refused: np.ndarray,
        snap_errors: np.ndarray | None,
        gaps: np.ndarray | None,
    ) -> dict[str, dict[str, Any]]:
        all_live = len(live) == self.num_robots  # no copies in the usual case
        here, packages, deliveries = self._here, self._package_index, self._deliveries
        if not all_live:
            here, packages, refused, deliveries = (
                a[live] for a in (here, packages, refused, deliveries)
            )
        optimal = self.distances.lookup(here, packages)
        extra: dict[str, list] = {}
        if self._errands is not None:
            extra["tasks"] = self._errands.tasks_per_robot[live].tolist()
        if self.physics:
            if snap_errors is None:  # at a reset
                snap_errors, gaps = np.zeros(self.num_robots), np.full(self.num_robots, np.inf)
            extra["snap_error"] = snap_errors[live].astype(float).tolist()
            if self.track_gaps:
                extra["min_gap"] = gaps[live].astype(float).tolist()
        return robot_infos(self.agents, optimal.tolist(), refused.tolist(), deliveries.tolist(),
                           extra)  # fmt: skip

    def _package_list(self) -> list[tuple[int, int]]:
        return [tuple(p) for p in self._packages.tolist()]


def _instance_of(
    instance: LorrInstance | str | os.PathLike[str] | None,
    floor: dict[str, object],
    starts: str,
    scheduler: Scheduler | None,
) -> LorrInstance | None:
    """``instance`` as a :class:`LorrInstance` (read from its path), with the fleet's
    floor arguments (``floor``: those given) refused beside it."""
    if instance is None:
        if scheduler is not None:
            raise ValueError("scheduler is for a fleet of an instance (instance=...)")
        return None
    given = [name for name, value in floor.items() if value is not None]
    if given or starts != "auto":
        names = ", ".join(given + ([] if starts == "auto" else ["starts"]))
        raise ValueError(f"an instance gives the floor and the starts; do not give {names}")
    return as_instance(instance)


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
            action = self.env._actions.one(agent, action)
        super().step(action)


def parallel_env(**kwargs: Any) -> WarehouseFleetEnv:
    """The fleet as a PettingZoo ``ParallelEnv`` (see :class:`WarehouseFleetEnv`)."""
    return WarehouseFleetEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The fleet as a PettingZoo AEC environment: robots act in turn, moves happen together."""
    return OrderEnforcingWrapper(_FleetAEC(parallel_env(**kwargs)))
