"""A fleet whose plans are executed asynchronously, a tick at a time, under delays.

``warehouse_phys.envs.async_fleet.parallel_env(layout="warehouse", num_robots=64,
ticks_per_move=10, delays=DelayConfig(...))`` is the PettingZoo face of
:class:`~warehouse_phys.execution.runner.Execution`; ``physics=True`` drives every robot
as a body of the physics twin
(:meth:`~warehouse_phys.physics.batched.BatchedPhysicsWorld.drive_tick`).
The environment composes those parts (floor, placement, errands, execution, bodies)
and holds no rule of its own; its observations, actions and infos also come as arrays
(:mod:`~warehouse_phys.envs.array_form`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo import AECEnv, ParallelEnv

from warehouse_phys.drawing.text_frames import fleet_ansi_frame
from warehouse_phys.envs.array_form import (
    ArrayStep,
    action_array,
    agent_dicts,
    info_dicts,
    step_dicts,
)
from warehouse_phys.envs.async_arguments import (
    ACTION_NAMES,
    GO,
    STOP,
    checked_async_action,
    checked_gap,
    delay_config,
    gap_and_steps,
)
from warehouse_phys.envs.checks import checked_reset_options
from warehouse_phys.envs.fleet.actions import aec_form
from warehouse_phys.envs.fleet.setup import MAX_PHYSICS_ROBOTS
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.runner import Execution, TickOutcome
from warehouse_phys.execution.ticks import (
    LORR_TICKS_PER_MOVE,
    check_ticks_per_move,
    check_whole,
    move_ticks,
)
from warehouse_phys.lorr.errands import NO_ERRAND, ErrandList, errand_list
from warehouse_phys.lorr.instances import LorrInstance, as_instance
from warehouse_phys.physics.batched import BatchedPhysicsWorld
from warehouse_phys.physics.config import (
    PhysicsConfig,
    check_physics_robots,
    physics_config_from,
)
from warehouse_phys.physics.regions import check_threads
from warehouse_phys.physics.safety import SafetyRecord
from warehouse_phys.physics.ticking import drive_executor_tick
from warehouse_phys.world.headings import HEADINGS, MOVE_MODELS, Heading
from warehouse_phys.world.layouts import make_grid
from warehouse_phys.world.placement import (
    check_room,
    draw_new_packages,
    draw_placement,
    package_cells,
    reachable_cells,
)

__all__ = ["DEFAULT_TICKS", "GO", "MAX_PHYSICS_ROBOTS", "STOP", "AsyncFleetEnv", "env",
           "parallel_env"]  # fmt: skip

#: Ticks an episode lasts by default.
DEFAULT_TICKS = 1000


class AsyncFleetEnv(ParallelEnv):
    """Robots that execute a planner's moves asynchronously, each move taking ticks, under delays.

    ## Description
    ``num_robots`` robots on one floor (a preset, a MovingAI ``.map`` file, rows and
    columns) or a League of Robot Runners instance's robots and errands. Every
    ``plan_every`` ticks PIBT plans a window of moves for every robot
    (:class:`~warehouse_phys.execution.runner.Execution`); a move takes
    ``ticks_per_move`` ticks (divided by a robot's speed factor, rounded up:
    :mod:`warehouse_phys.execution.ticks`); delays are drawn each tick as LoRR 2026 draws
    them (:mod:`warehouse_phys.execution.delays`); the executor
    (:mod:`warehouse_phys.execution.executor`) says GO or STOP to each robot each tick so
    that no two robots' centres ever come closer than ``min_gap`` cells, whatever the
    delays. With ``physics=True`` each robot is a disc in one pymunk space whose body
    follows its grid position tick by tick and is snapped when a move ends; the gap is
    then what the bodies need (:func:`~warehouse_phys.physics.tick_controller.required_min_gap`)
    and no two discs ever overlap by more than the collision slop.

    With ``moves="rotate"`` the robots are the League of Robot Runners' turning robots
    (:mod:`warehouse_phys.world.headings`): they start facing east, and a forward move
    or a quarter turn each takes a move's ticks; the planner is PIBT over cells and
    headings.

    ## Action Space
    ``Discrete(2)`` per robot, each tick: ``GO=1`` lets the executor drive the robot;
    ``STOP=0`` holds it where it is this tick. A held robot is, for the executor,
    delayed: the robots behind it wait, and every guarantee stands whatever the agent
    holds. An agent is thus a GO/STOP policy on top of the executor's (an RL agent that
    learns when holding a robot pays, or a person at the keyboard).

    ## Observation Space
    ``MultiDiscrete([R, C, R, C, R, C, K + 1, K + 1, 2, 2])`` per robot: its cell (the
    cell it is on or leaves), its goal (its own cell when it has none), the cell its
    move enters (its own at rest), the ticks of its move done, the ticks its moves take,
    whether it was delayed and whether the executor said GO in the last tick (``K``:
    the most ticks any robot's move takes). Turning robots: then their heading and the
    heading their action ends facing (``MultiDiscrete([..., 4, 4])``).

    ## Starting State
    Robots on distinct cells drawn from the reachable cells, packages drawn among the
    floor's package cells (:mod:`warehouse_phys.world.placement`); an instance's robots
    on its starts with its first errands.

    ## Rewards
    1.0 to a robot on the tick it finishes an errand (reaches its package, or its
    instance errand, at rest), else 0.0. A robot that finishes one gets the next at
    once (lifelong).

    ## Episode End
    Truncation after ``max_cycles`` ticks; robots never terminate.

    ``infos[robot]``: ``go`` (the executor's command), ``advanced``, ``delayed``,
    ``held``, ``knock_on`` (stood still for a robot ahead), ``errands`` (this episode's),
    and with physics ``snap_error`` (cells, for a move that ended this tick, else 0) and,
    measured at every physics step (``safety=True``, the default), ``closest_approach``
    (the closest another body's centre came to this robot's this episode [cells], ``inf``
    beyond a cell), ``body_contacts`` and ``wall_contacts`` (its contacts deeper than the
    collision slop; :attr:`safety` has the fleet's).
    :attr:`execution` holds the executor and the measures; :attr:`world` the bodies.

    ``reset_arrays``/``step_arrays`` are the same episode with arrays in robot order
    instead of dicts (:mod:`~warehouse_phys.envs.array_form`).

    ## Arguments
    - ``num_robots`` (int; an instance's ``teamSize``), ``layout``, ``grid_rows``,
      ``grid_cols``: the floor, as in :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`.
    - ``instance``: a :class:`~warehouse_phys.lorr.instances.LorrInstance` or its JSON
      path; its ``agentCounter`` and ``delayConfig`` are the defaults of
      ``ticks_per_move`` and ``delays``; ``scheduler``, ``record_errands`` as the fleet's.
    - ``moves`` (``"grid"``, default: four directions; ``"rotate"``: turning robots).
    - ``ticks_per_move`` (int, default LoRR's 10), ``speeds`` (``(N,)`` speed factors).
    - ``delays`` (:class:`~warehouse_phys.execution.delays.DelayConfig`, its JSON dict, or
      ``None``: no delays). Delays are drawn from the configuration's own seed, as LoRR
      draws them: every episode has the same delays unless ``reset(options={"delays":
      ...})`` gives another configuration.
    - ``plan_every`` (ticks, default ``ticks_per_move``), ``window`` (steps, default 1),
      ``planner`` (``"pibt"``, default, ``"guided"`` or any other planner by name: the
      windows' planner, :data:`~warehouse_phys.execution.windows.WINDOW_PLANNERS`),
      ``guidance`` (a guided planner's fields, ``{"reroute": 32}`` say; default its own),
      ``around_delays`` (``"wait"``, ``"reroute"``, ``"off"``: how the windows treat
      delayed robots, :class:`~warehouse_phys.execution.runner.Execution`),
      ``min_gap`` (cells; default the executor's, with physics what the bodies need;
      a smaller one than the bodies need is refused).
    - ``physics`` (bool), ``tick_steps`` (physics steps a tick), the physical keywords
      of :class:`~warehouse_phys.physics.PhysicsConfig`; ``track_gaps`` (bool): record
      every body's path to measure :meth:`closest_approach`; ``safety`` (bool, default
      True): measure every physics step (:attr:`safety`); ``physics_threads`` (1 to 64,
      default 1): the bodies held in that many regions of the floor, stepped in parallel
      (:mod:`~warehouse_phys.physics.regions`: the same bodies for a seed and a number
      of threads, and the one-space bodies while no two touch). The physics twin takes
      as many robots as this machine's memory holds (:data:`MAX_PHYSICS_ROBOTS`).
    - ``max_cycles`` (ticks, default 1,000), ``seed`` (the planner's tie-breaks, 0 to
      2^63 - 1),
      ``render_mode`` (``None`` or ``"ansi"``).

    ## Version History
    - v0: first version.
    """

    metadata: dict[str, Any] = {  # noqa: RUF012 - PettingZoo reads this class attribute
        "name": "warehouse_async_fleet_v0",
        "render_modes": ["ansi"],
        "render_fps": 30,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        num_robots: int | None = None,
        *,
        layout: str | os.PathLike[str] | None = None,
        grid_rows: int | None = None,
        grid_cols: int | None = None,
        instance: LorrInstance | str | os.PathLike[str] | None = None,
        moves: str = "grid",
        ticks_per_move: int | None = None,
        speeds: Any = None,
        delays: DelayConfig | dict[str, Any] | None = None,
        plan_every: int | None = None,
        window: int = 1,
        around_delays: str = "wait",
        planner: str = "pibt",
        guidance: Mapping[str, Any] | None = None,
        min_gap: float | None = None,
        physics: bool = False,
        tick_steps: int | None = None,
        track_gaps: bool = False,
        safety: bool = True,
        physics_threads: int = 1,
        max_cycles: int = DEFAULT_TICKS,
        scheduler: Any = None,
        record_errands: bool = False,
        seed: int = 0,
        render_mode: str | None = None,
        **physical: Any,
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'ansi', got {render_mode!r}")
        self.render_mode = render_mode
        self.instance = None if instance is None else as_instance(instance)
        if self.instance is not None:
            given = {"num_robots": num_robots, "layout": layout, "grid_rows": grid_rows,
                     "grid_cols": grid_cols}  # fmt: skip
            if any(value is not None for value in given.values()):
                names = ", ".join(k for k, v in given.items() if v is not None)
                raise ValueError(f"an instance gives the floor and the robots; do not give {names}")
            self.grid = self.instance.grid
            num_robots = self.instance.team_size
            ticks_per_move = ticks_per_move or self.instance.agent_counter or LORR_TICKS_PER_MOVE
            delays = self.instance.delay if delays is None else delays
        else:
            self.grid = make_grid(grid_rows, grid_cols, layout)
            ticks_per_move = LORR_TICKS_PER_MOVE if ticks_per_move is None else ticks_per_move
        self.num_robots = check_whole("num_robots", 2 if num_robots is None else num_robots, 1,
                                      10**6)  # fmt: skip
        if moves not in MOVE_MODELS:
            raise ValueError(f"moves must be one of {', '.join(MOVE_MODELS)}, got {moves!r}")
        #: ``"grid"`` (four directions) or ``"rotate"`` (LoRR's turning robots).
        self.moves = moves
        self.max_cycles = check_whole("max_cycles", max_cycles, 1, 10**9)
        self.delays = delay_config(delays)
        self.physics: PhysicsConfig | None = physics_config_from(physical) if physics else None
        if not physics and physical:
            raise TypeError(f"physical keywords {sorted(physical)} need physics=True")
        self.physics_threads = check_threads(physics_threads)
        seed = check_whole("seed", seed, 0, 2**63 - 1)
        if guidance is not None and not isinstance(guidance, Mapping):
            raise TypeError(f"guidance must be a mapping of a guided planner's fields, got "
                            f"{type(guidance).__name__}")  # fmt: skip
        self._options = {"ticks_per_move": ticks_per_move, "speeds": speeds,
                         "plan_every": plan_every, "window": window,
                         "around_delays": around_delays, "seed": seed,
                         "planner": planner, "guidance": dict(guidance or {})}  # fmt: skip
        self._reachable = reachable_cells(self.grid)
        self._targets = package_cells(self.grid)
        if self.instance is None:
            check_room(self.num_robots, "random", True, self._targets, self._reachable, None)
            placeholder = self._reachable[: self.num_robots]
        else:
            placeholder = self.instance.starts
        self._errands: ErrandList | None = None
        if self.instance is not None:
            self._errands = errand_list(self.instance, scheduler=scheduler, record=record_errands)
        if self.physics is not None:
            check_physics_robots(self.num_robots)
        needed = move_ticks(check_ticks_per_move(ticks_per_move), self.num_robots, speeds)
        self.tick_steps, self.min_gap = gap_and_steps(
            self.physics, self.turning, checked_gap(min_gap), tick_steps, needed
        )
        # Built once here to check every argument; each reset builds the episode's.
        self.execution = self._new_execution(np.stack(np.divmod(placeholder, self.grid.cols), 1))
        self.track_gaps, self._safety = bool(track_gaps), bool(safety)
        self.world: BatchedPhysicsWorld | None = None
        self.possible_agents = [f"robot_{i}" for i in range(self.num_robots)]
        self.agents: list[str] = []
        most = int(needed.max()) + 1
        rows, cols = self.grid.rows, self.grid.cols
        sizes = [rows, cols, rows, cols, rows, cols, most, most, 2, 2]
        self._observation_space = spaces.MultiDiscrete(sizes + [HEADINGS] * self.turning * 2)
        self._action_space = spaces.Discrete(2)
        self.np_random, _ = seeding.np_random(None)
        self._goals = np.zeros(self.num_robots, dtype=np.int64)
        self._errands_done = np.zeros(self.num_robots, dtype=np.int64)
        self._last: TickOutcome | None = None

    # ------------------------------------------------------------------ PettingZoo
    def observation_space(self, agent: str) -> spaces.MultiDiscrete:
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._action_space

    def step(self, actions: dict[str, int]) -> tuple[dict, dict, dict, dict, dict]:
        """One tick: hold the robots whose action is STOP, let the executor drive the rest."""
        if not self.agents:
            raise ValueError("call reset() before step(): the episode has ended")
        agents = self.agents
        return step_dicts(agents, self._tick(self._holds(actions)))

    def step_arrays(self, actions: np.ndarray) -> ArrayStep:
        """:meth:`step` with ``actions`` an ``(N,)`` integer array of GO/STOP in robot order,
        and arrays back (:class:`~warehouse_phys.envs.array_form.ArrayStep`)."""
        if not self.agents:
            raise ValueError("call reset() before step(): the episode has ended")
        return self._tick(action_array(actions, self.num_robots, 2, ACTION_NAMES) == STOP)

    def _tick(self, hold: np.ndarray) -> ArrayStep:
        executor = self.execution.executor
        left_before, done_before = executor.left.copy(), executor.done.copy()
        faced = None if executor.headings is None else executor.headings.copy()
        outcome = self.execution.tick(self._goal_cells(), hold)
        snap = None if self.world is None else drive_executor_tick(
            self.world, executor, left_before, done_before, faced, outcome.report.ended,
            self.tick_steps)  # fmt: skip
        arrived = (executor.done == 0) & (executor.left == self._goals)
        if self._errands is not None:
            arrived &= self._errands.goals >= 0
        self._new_goals(arrived)
        self._last = outcome
        n, done = self.num_robots, executor.tick >= self.max_cycles
        result = ArrayStep(self._observation_table(), arrived.astype(float),
                           np.zeros(n, dtype=bool), np.full(n, done),
                           self._info_columns(snap))  # fmt: skip
        if done:
            self.agents = []
        return result

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Robots on their starts with their first goals, tick 0; ``seed`` seeds the
        placement; ``options={"delays": DelayConfig or dict or None}`` changes the delays
        (any other option is refused)."""
        table, columns = self.reset_arrays(seed, options)
        return agent_dicts(self.agents, table), info_dicts(self.agents, columns)

    def reset_arrays(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """:meth:`reset`, with every robot's observation as a row of one ``(N, K)`` array
        and the infos as ``(N,)`` arrays (:mod:`~warehouse_phys.envs.array_form`)."""
        options = checked_reset_options(options, ("delays",))
        if seed is not None:
            self.np_random, _ = seeding.np_random(check_whole("seed", seed, 0, 2**63 - 1))
        if "delays" in options:
            self.delays = delay_config(options["delays"])
        if self._errands is not None:
            here = self.instance.starts.astype(np.int64)
            self._errands.reset(here)
            self._goals = np.where(self._errands.goals >= 0, self._errands.goals, here)
        else:
            here, self._goals = draw_placement(
                self.np_random, self.num_robots, self._targets, self._reachable, None
            )
        cells = np.stack(np.divmod(here, self.grid.cols), axis=1)
        self.execution = self._new_execution(cells)
        if self.physics is not None:
            self.world = BatchedPhysicsWorld(self.grid, self.physics, cells,
                                             np.zeros(self.num_robots, dtype=np.int64),
                                             record_path=self.track_gaps,
                                             headings=self.execution.executor.headings,
                                             threads=self.physics_threads,
                                             safety=self._safety)  # fmt: skip
        self._errands_done[:] = 0
        self._last = None
        self.agents = list(self.possible_agents)
        return self._observation_table(), self._info_columns(None)

    def render(self) -> str | None:
        """``"ansi"``: the floor as text, robots as digits on the cell they are on or leave."""
        if self.render_mode is None:
            return None
        cols = self.grid.cols
        cells = np.stack(np.divmod(self.execution.executor.left, cols), axis=1).tolist()
        goals = np.stack(np.divmod(self._goals, cols), axis=1).tolist()
        return fleet_ansi_frame(self.grid.rows, cols, cells, goals, [True] * self.num_robots,
                                self.grid.shelves)  # fmt: skip

    def close(self) -> None:
        self.world = None

    # ------------------------------------------------------------------ state
    @property
    def turning(self) -> bool:
        """Whether the robots are turning robots (``moves="rotate"``)."""
        return self.moves == "rotate"

    @property
    def errands(self) -> ErrandList | None:
        """An instance fleet's errand list (errands and tasks finished), else ``None``."""
        return self._errands

    @property
    def errands_done(self) -> int:
        """Errands finished this episode, every robot's."""
        return int(self._errands_done.sum())

    @property
    def ticks(self) -> int:
        """Ticks run this episode."""
        return self.execution.executor.tick

    @property
    def safety(self) -> SafetyRecord | None:
        """The bodies' closest approach and contacts deeper than the collision slop this
        episode (:class:`~warehouse_phys.physics.safety.SafetyRecord`; ``None`` without
        physics or with ``safety=False``)."""
        return None if self.world is None else self.world.safety

    def checked_action(self, agent: str, action: object) -> int:
        """``action`` as STOP (0) or GO (1), or a ``TypeError``/``ValueError`` naming
        ``agent`` (the AEC form checks each robot's action as it is given)."""
        return checked_async_action(agent, action)

    def closest_approach(self) -> float:
        """The smallest distance between two bodies' centres at the physics steps of the
        last tick [cells] (physics with ``track_gaps=True``): never below the robots'
        diameter less the collision slop."""
        if self.world is None or not self.track_gaps:
            raise ValueError("closest_approach needs physics=True and track_gaps=True")
        return float(self.world.closest_approach().min(initial=np.inf))

    # ------------------------------------------------------------------ parts
    def _new_execution(self, cells: np.ndarray) -> Execution:
        headings = np.full(len(cells), Heading.EAST) if self.turning else None  # LoRR's start
        return Execution(self.grid, cells, delays=self.delays, min_gap=self.min_gap,
                         headings=headings, **self._options)  # fmt: skip

    def _holds(self, actions: dict[str, int]) -> np.ndarray:
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict of robot to action, got "
                            f"{type(actions).__name__}")  # fmt: skip
        if set(actions) != set(self.agents):
            missing = sorted(set(self.agents) - set(actions))[:3]
            unknown = sorted(map(str, set(actions) - set(self.agents)))[:3]
            raise ValueError(f"actions must name every live robot and no other; missing "
                             f"{missing}, unknown {unknown}")  # fmt: skip
        checked = (checked_async_action(agent, actions[agent]) for agent in self.agents)
        values = np.fromiter(checked, np.int64, len(self.agents))
        return values == STOP

    def _new_goals(self, arrived: np.ndarray) -> None:
        self._errands_done += arrived
        here = self.execution.executor.left
        if self._errands is not None:
            self._errands.step(np.flatnonzero(arrived), here)
            self._goals = np.where(self._errands.goals != NO_ERRAND, self._errands.goals, here)
        elif arrived.any():
            robots = np.flatnonzero(arrived)
            self._goals[robots] = draw_new_packages(
                self.np_random, self._targets, self.grid.rows * self.grid.cols, here,
                self._goals, robots,
            )  # fmt: skip

    def _goal_cells(self) -> np.ndarray:
        return np.stack(np.divmod(self._goals, self.grid.cols), axis=1)

    def _observation_table(self) -> np.ndarray:
        executor, cols = self.execution.executor, self.grid.cols
        last = self._last
        n = self.num_robots
        flags = (np.zeros((n, 2), dtype=np.int64) if last is None else
                 np.stack([last.delayed, last.report.go], axis=1).astype(np.int64))  # fmt: skip
        columns = [
            np.stack(np.divmod(executor.left, cols), axis=1), self._goal_cells(),
            np.stack(np.divmod(executor.entered, cols), axis=1),
            executor.done[:, None], executor.ticks_needed[:, None], flags,
        ]  # fmt: skip
        if self.turning:
            columns += [executor.headings[:, None], executor.facing[:, None]]
        return np.concatenate(columns, axis=1)

    def _info_columns(self, snap: np.ndarray | None) -> dict[str, np.ndarray]:
        n = self.num_robots
        last = self._last
        none = np.zeros(n, dtype=bool)
        go, advanced = (none, none) if last is None else (last.report.go, last.report.advanced)
        delayed, held = (none, none) if last is None else (last.delayed, last.held)
        knock_on = none if last is None else last.report.knock_on
        columns = {"go": go, "advanced": advanced, "delayed": delayed, "held": held,
                   "knock_on": knock_on, "errands": self._errands_done}  # fmt: skip
        if self.physics is not None:
            columns["snap_error"] = np.zeros(n) if snap is None else snap
        record = self.safety
        if record is not None:
            columns |= {"closest_approach": record.robot_closest.copy(),
                        "body_contacts": record.robot_body_contacts.copy(),
                        "wall_contacts": record.robot_wall_contacts.copy()}  # fmt: skip
        return columns


def parallel_env(**kwargs: Any) -> AsyncFleetEnv:
    """The asynchronous fleet (PettingZoo's parallel form); see :class:`AsyncFleetEnv`."""
    return AsyncFleetEnv(**kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The asynchronous fleet as a PettingZoo AEC environment, each robot's action checked
    as it is given (a bad one is refused at once, and nothing changes)."""
    return aec_form(parallel_env(**kwargs))
