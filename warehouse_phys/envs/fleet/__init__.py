"""A fleet of robots on one warehouse floor, as PettingZoo environments.

``warehouse_phys.envs.fleet.parallel_env(**kwargs)`` returns a :class:`WarehouseFleetEnv`
(a PettingZoo ``ParallelEnv``); ``warehouse_phys.envs.fleet.env(**kwargs)`` the same as
an AEC environment (PettingZoo's ``parallel_to_aec``, refusing a bad action at once).

Here are its specification (the class docstring) and its step and reset glue; what it
composes has a module each (``fleet_setup``, ``fleet_state``, ``fleet_actions``,
``fleet_observations``, ``fleet_physics``), and the rules it applies live in
:mod:`warehouse_phys.world`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv, ParallelEnv

from warehouse_phys.drawing.render import DEFAULT_CELL_PX, WarehouseRenderer
from warehouse_phys.drawing.text_frames import fleet_ansi_frame
from warehouse_phys.envs.checks import checked_reset_options
from warehouse_phys.envs.fleet.actions import FleetActions, aec_form
from warehouse_phys.envs.fleet.arrays import FleetArrayForm
from warehouse_phys.envs.fleet.observations import (
    MAX_GLOBAL_OBSERVATION_ROBOTS,
    NEIGHBOUR_BITS,
    OBSERVATIONS,
    FleetObservations,
)
from warehouse_phys.envs.fleet.physics import drive_bodies, motion_frames, started_world
from warehouse_phys.envs.fleet.setup import (
    DELIVERY_MODES,
    LORR_STEPS,
    MAX_PHYSICS_ROBOTS,
    set_up_fleet,
)
from warehouse_phys.envs.fleet.state import FleetState
from warehouse_phys.lorr.instances import LorrInstance
from warehouse_phys.lorr.scheduling import Scheduler
from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.physics.regions import check_threads
from warehouse_phys.world.batched import step_rewards
from warehouse_phys.world.headings import TURN_ACTIONS, joint_grants
from warehouse_phys.world.placement import START_MODES
from warehouse_phys.world.traffic import FLEET_ACTIONS

if TYPE_CHECKING:  # the bodies are imported with their first world (envs.fleet.physics)
    from warehouse_phys.physics.batched import BatchedPhysicsWorld
    from warehouse_phys.physics.safety import SafetyRecord

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


class WarehouseFleetEnv(FleetState, FleetArrayForm, ParallelEnv):
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
    ``track_gaps=False`` leaves both out, and ``min_gap`` with them. Measured at every
    physics step (``safety=True``, the default): ``closest_approach`` (the closest another
    body's centre came to this robot's this episode [cells], ``inf`` beyond a cell),
    ``body_contacts`` and ``wall_contacts`` (its contacts deeper than the collision slop;
    a bump into a wall or shelf sinks in a little); :attr:`safety` has the fleet's.
    ``reset_arrays``/``step_arrays`` are the same episode with arrays in robot order
    instead of dicts (:mod:`~warehouse_phys.envs.array_form`).

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
      ``min_gap``; ``safety`` (bool, default True): whether it measures every physics
      step (:attr:`safety`); ``physics_threads`` (1 to 64, default 1): the bodies held in
      that many regions of the floor, stepped in parallel
      (:mod:`~warehouse_phys.physics.regions`). The physics world takes as many robots
      as this machine's memory holds (:data:`MAX_PHYSICS_ROBOTS`).

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
        safety: bool = True,
        physics_threads: int = 1,
        **physical: float,
    ) -> None:
        setup = set_up_fleet(
            num_robots=num_robots, physics=physics, grid_rows=grid_rows, grid_cols=grid_cols,
            layout=layout, lifelong=lifelong, max_cycles=max_cycles, observation=observation,
            render_mode=render_mode, render_modes=self.metadata["render_modes"],
            on_delivery=on_delivery, starts=starts, track_gaps=track_gaps, moves=moves,
            instance=instance, scheduler=scheduler, record_errands=record_errands,
            safety=safety, physical=physical,
        )  # fmt: skip
        self.physics_threads, self._safety = check_threads(physics_threads), safety
        self.instance, self.grid, self.num_robots = setup.instance, setup.grid, setup.num_robots
        self.on_delivery, self.max_cycles = setup.on_delivery, setup.max_cycles
        self.observation, self.render_mode, self._track_gaps = observation, render_mode, track_gaps
        #: The move model: ``"grid"`` (four directions) or ``"rotate"`` (turning robots).
        self.moves = moves
        #: The physics world's parameters, as in every environment; ``None`` in the grid twin.
        self.physics: PhysicsConfig | None = setup.physics
        #: Whether the traffic rule grants corner follows (robots small enough to pass).
        self.corner_follows = setup.corner_follows
        placement = setup.placement
        self.starts_mode, self._errands = placement.starts_mode, placement.errands
        self._targets, self._reachable = placement.targets, placement.reachable
        self._layout_starts_index = placement.layout_starts

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
        self._init_state()
        self.world: BatchedPhysicsWorld | None = None
        self._renderer = WarehouseRenderer.for_grid(
            self.grid, cell_px=cell_px, render_fps=self.metadata["render_fps"]
        )
        if render_mode == "rgb_array":
            self._renderer.check_frame_size()

    def observation_space(self, agent: str) -> spaces.MultiDiscrete | spaces.Box:
        """The observation space of ``agent`` (the same object on every call)."""
        self._checked_agent(agent)
        return self._observer.space

    def action_space(self, agent: str) -> spaces.Discrete:
        """``Discrete(5)``: the four moves and WAIT; turning robots ``Discrete(4)``:
        forward, the two turns and WAIT (the same object on every call)."""
        self._checked_agent(agent)
        return self._action_space

    @property
    def safety(self) -> SafetyRecord | None:
        """The bodies' closest approach and contacts deeper than the collision slop this
        episode (:class:`~warehouse_phys.physics.safety.SafetyRecord`; ``None`` in the
        grid twin or with ``safety=False``)."""
        return None if self.world is None else self.world.safety

    def checked_action(self, agent: str, action: object) -> int:
        """``action`` as an int of the action space, or an error naming ``agent`` (the AEC
        form checks each robot's action as it is given)."""
        return self._actions.one(agent, action)

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Every robot on a start cell with a new package (an instance fleet: its first
        errand); ``seed`` seeds the generator. The fleet takes no ``options``: any is
        refused but PettingZoo's tests' probe (``{"options": ...}``, ignored).
        """
        checked_reset_options(options, ())
        if seed is not None:
            self.np_random, _ = seeding.np_random(seed)
        n = self.num_robots
        self._place_robots()
        self.agents = list(self.possible_agents)
        if self.physics:
            self.world = started_world(
                self.world, self.grid, self.physics, self._cells, self._headings,
                record_path=self.track_gaps or self.render_mode == "rgb_array",
                threads=self.physics_threads, safety=self._safety,
            )  # fmt: skip
        live = np.arange(n)
        refused = np.zeros(n, dtype=bool)
        return self._observations(live), self._infos(live, refused, None, None)

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        """Move every live robot by its action under the traffic rule."""
        if not self.agents:
            raise ValueError("the episode is over (no live robots): call reset()")
        live = self._live_indices()
        joint = self._actions.joint(actions, self.agents, live)
        return self._joint_step(joint, live)

    def _joint_step(self, joint: np.ndarray, live: np.ndarray, *, arrays: bool = False) -> Any:
        """The step of the checked ``joint`` action; its PettingZoo dicts, or (``arrays``)
        its :class:`ArrayStep`."""
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
        if self.physics:  # the granted moves and the bumps driven, the rest held
            ends, headings, snap_errors, gaps = drive_bodies(
                self.world, joint, ends, bumped, headings, turning=self.turning,
                track_gaps=self.track_gaps,
            )  # fmt: skip
            # The cells (and headings) read from the bodies: the same, as the tests prove.
            moved = ends[:, 0] * cols + ends[:, 1]
        if headings is not None:
            self._headings = headings
        self._cell_rows_cols, self._here = ends, moved  # the cells and their indices
        self._steps += 1
        arrived, delivered = self._deliver(moved, live)
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
        if arrays:
            result = self._array_step(live, arrived, refused, snap_errors, gaps, truncated)
        else:
            observations = self._observations(live)
            infos = self._infos(live, refused, snap_errors, gaps)
        if truncated:
            self.agents = []
        elif not self.lifelong and delivered.size:
            self.agents = [agent for agent, ended in zip(agents, ends_robot, strict=True)
                           if not ended]  # fmt: skip
        if arrays:
            return result
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
        return motion_frames(self.world, self._renderer, self._package_list(),
                             turning=self.turning)  # fmt: skip

    def close(self) -> None:
        """Release the renderer's pygame resources."""
        self._renderer.close()

    def state(self) -> np.ndarray:
        """The global picture: every robot's ``[row, col, package_row, package_col]`` (and
        heading, for turning robots)."""
        return self._observer.state(self._cells, self._packages, self._headings)

    # ------------------------------------------------------------------ helpers
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

    def _package_list(self) -> list[tuple[int, int]]:
        return [tuple(p) for p in self._packages.tolist()]


def parallel_env(**kwargs: Any) -> WarehouseFleetEnv:
    """The fleet as a PettingZoo ``ParallelEnv`` (see :class:`WarehouseFleetEnv`)."""
    return WarehouseFleetEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The fleet as a PettingZoo AEC environment: robots act in turn, moves happen together."""
    return aec_form(parallel_env(**kwargs))
