"""Traffic guidance for PIBT: guide paths that keep robots out of each other's way.

Plain PIBT (:mod:`warehouse_phys.planners.pibt`) sends every robot along a shortest path
and settles each meeting greedily; at warehouse densities robots heading opposite ways
meet head-on in one-cell aisles. Chen, Harabor, Li and Stuckey ("Traffic Flow
Optimisation for Lifelong Multi-Agent Path Finding", AAAI 2024) give each robot a *guide
path* priced by the others' guide paths, and let PIBT follow it. Here:

- :class:`TrafficGuidance` keeps every robot's guide path and the *flow*, how many guide
  paths leave each cell by each move (the part a robot has still to drive: the moves it
  made are taken off as it makes them). A robot's guide path is searched anew when it
  gets a new goal, when PIBT moved it off its path (pushed aside or back), and for
  ``refresh`` other robots a step (in turn): an A* whose move from ``u`` to ``v`` costs
  ``1 + vertex_weight * (guide paths leaving v) + contraflow_weight * (paths u->v + 1) *
  (paths v->u)`` (:func:`~warehouse_phys.planners.traffic_flow.congestion_path`). A robot
  that moved beside a cell further along its path rejoins it there without a search
  (``rejoin=True``: also one pushed aside; on MR23-I-10 searching anew did better).
  Long guide paths make the searches of pushed robots dear (each prices the whole way
  to the goal again), so a robot pushed off a path with more than ``2 * reroute`` cells
  left may search only to the path's cell ``reroute`` past where it stood, and keep the
  path from there (``reroute``; 0, the default: a new search to the goal).
- Turning robots (``moves="rotate"``): a quarter turn costs ``turn_cost`` more in their
  guide paths' search, from the way the robot faces when it is searched, so of equally
  priced paths it takes one with few turns (on MR23-I-10, 6 % more errands over the first
  300 steps than paths searched as a four-direction robot's, at the same cost a step).
  A turn holds up the robots behind the turning robot for a step, so a turn where many
  guide paths pass costs more (``turn_traffic_weight``: ``turn_cost`` times one plus
  the weight times the guide paths leaving the cell); on MR23-I-10 with 0.5, 29.65
  errands a step over 5,000 steps against 28.45 with 0, at a cheaper step. Meeting a
  robot head-on, a turning robot must turn round or wait, so contraflow costs it
  ``turn_contraflow_weight`` (4 by default) instead of ``contraflow_weight`` (1).
- One-way lanes for turning robots: every cell of a one-cell-wide corridor carries
  ``turn_lane_paths`` (2) phantom guide paths along its lane
  (:func:`~warehouse_phys.planners.lanes.one_way_lanes`: neighbouring corridors run
  opposite ways), laid in the flow at the first update with ``facing``, so that a guide
  path against a lane pays that contraflow and robots going opposite ways take
  neighbouring corridors instead of meeting in one (every price of the flow sees them: a
  move into a lane's cell, and a turn on one, cost a little more too). The figures are
  in the documentation's LoRR page (``docs/lorr.md``, "One-way lanes"). Lanes can cover
  the whole floor, open bands included (``floor_lane_paths``,
  :func:`~warehouse_phys.planners.lanes.floor_lanes`), or be learned from the fleet's
  own traffic (``learned_lane_paths``,
  :class:`~warehouse_phys.planners.lanes.learned.TrafficLanes`); both are phantom
  paths that only a search's contraflow sees (:attr:`TrafficGuidance.lanes`).
- Following (``follow=True``): a candidate cell of a robot is valued by its guide path,
  the moves left along it from the path cell it is on or beside (one more beside), as
  guided PIBT does; so PIBT moves it along its path, and pushes and backtracks as ever.
  Without following, the candidates keep their distances to the goal plus a share below
  one move of the contraflow on the move (a tie-break towards the traffic's way); robots
  then leave their guide paths often, and each departure is a search (an ablation, slow
  on big fleets).
- Bounded work: at most ``max_searches`` searches and ``time_limit`` seconds of guidance
  a step; robots left without a guide path are valued by PIBT's own distances (``NaN``
  values), so a step is always PIBT's, and every plan traffic grants; the next step
  searches them first. The first step, when every robot needs its first guide path, can
  have a time bound of its own (``first_time_limit``; ``math.inf`` for none), and the
  later steps a count of their own (``later_max_searches``) and a bound on the cells
  their searches expand (``later_max_expanded``: their work, the same on any machine).
  The searches run in batches of
  ``search_batch`` (the first step's: ``first_search_batch``, at most a hundredth of
  its searches) against one flow, on
  ``workers`` threads (:mod:`~warehouse_phys.planners.guide_searches`): the same paths
  for any number of threads.

Every knob is a field of :class:`~warehouse_phys.planners.guidance_config.GuidanceConfig`;
the guide paths' searches and the flow's bookkeeping are compiled in
:mod:`warehouse_phys.planners.traffic_flow`.

Deterministic for a seed and the same inputs, as long as ``time_limit`` is not reached
(:attr:`TrafficGuidance.timed_out` counts the robots it left unguided). Like the other
rules, it imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import math
import time

import numpy as np

from warehouse_phys.planners import graph_search, traffic_flow
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.guidance_config import FIRST_BATCH_SHARE, GuidanceConfig
from warehouse_phys.planners.guide_searches import GuidePaths, GuideSearches
from warehouse_phys.planners.lanes import NO_LANE, floor_lanes, one_way_lanes
from warehouse_phys.planners.lanes.learned import TrafficLanes
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.traffic import FLEET_ACTIONS, WAIT, neighbour_table


class TrafficGuidance:
    """Guide paths for a fleet on one floor, priced by their own traffic (the module's
    docstring), and the values PIBT ranks candidate cells by.

    Call :meth:`update` once a step with every robot's cell and goal (cell indices
    ``row * cols + col``); it returns ``(N, 5)`` candidate values for
    :meth:`~warehouse_phys.planners.pibt.PIBT.plan`'s ``candidate_values``.

    Args:
        grid: The floor.
        config: Prices, refreshes and bounds (:class:`GuidanceConfig`).
    """

    def __init__(self, grid: WarehouseGrid, config: GuidanceConfig | None = None) -> None:
        self.grid = grid
        self.config = GuidanceConfig() if config is None else config
        self._free = np.asarray(grid.free_mask, dtype=bool)
        free_cells = np.flatnonzero(self._free.reshape(-1))
        self._column = np.full(grid.rows * grid.cols + 1, -1, dtype=np.int64)  # last: -1
        self._column[free_cells] = np.arange(len(free_cells))
        self._cell_row = (free_cells // grid.cols).astype(np.int32)
        self._cell_col = (free_cells % grid.cols).astype(np.int32)
        self._table = neighbour_table(grid)
        self._held = np.empty(0, dtype=np.int64)
        self._floor_graph = graph_search.move_graph(self._free)
        self._graph = self._floor_graph
        n = len(free_cells)
        #: How many guide paths leave each cell (map column) by each move; for turning
        #: robots, the lanes' phantom paths (``config.turn_lane_paths``) included.
        self.flow = np.zeros((n, 4), dtype=np.int32)
        lanes = one_way_lanes(self._free)
        self._lane_columns = np.flatnonzero(lanes != NO_LANE)
        self._lane_moves = lanes[self._lane_columns].astype(np.int64)
        self._lanes_laid = False
        #: Phantom guide paths along the floor's lanes (``config.floor_lane_paths``), which
        #: only the contraflow of a search sees.
        self.lanes = np.zeros((n, 4), dtype=np.int32)
        self._laid_lanes = self.lanes.copy()  # the floor's, without the learned ones
        #: Lanes learned from the fleet's traffic (``config.learned_lane_paths``), if any.
        self.learner: TrafficLanes | None = None
        if self.config.learned_lane_paths:
            self.learner = TrafficLanes(self._floor_graph, paths=self.config.learned_lane_paths,
                                        period=self.config.learn_period)  # fmt: skip
            if self.config.learned_lanes_file is not None:
                self.learner.load(self.config.learned_lanes_file, self._free)
        self._searches = GuideSearches(self._cell_row, self._cell_col, self.config.workers)
        self._facing: np.ndarray | None = None
        self._paths = GuidePaths.empty(0)
        self._turn = 0  # the next robot whose guide path is refreshed
        self._first = True  # no step planned yet: first_time_limit bounds the next
        self._guided = np.zeros(0, dtype=bool)  # robots with a guide path after the update
        #: Guide-path searches made in the last step, the cells they expanded together,
        #: and robots left unguided because the step's time, searches or cells ran out.
        self.searches = 0
        self.expanded = 0
        self.timed_out = 0
        #: Wall time of the last step's searches [s].
        self.search_seconds = 0.0

    def update(
        self,
        here: np.ndarray,
        goal: np.ndarray,
        active: np.ndarray,
        distances: DistanceMaps | None = None,
        held: np.ndarray | None = None,
        facing: np.ndarray | None = None,
        deadline: float | None = None,
    ) -> np.ndarray:
        """One step's guidance: each ``active`` robot's guide path brought up to date
        (moved along, rejoined, searched anew within the step's bounds and before
        ``deadline``, a :func:`time.perf_counter` instant, if given), then the values of
        its five candidate cells (its four moves in action order, then its own cell), lower
        better, ``NaN`` where it has no guide path (and every row but the active robots').
        ``held`` cells (robots that never move again) are walls to the guide paths.
        Without following, ``distances`` (the planner's) give the values' distances.
        Turning robots give ``facing``, the move (0..3, grid action order) each faces:
        their guide paths are searched with ``config.turn_cost`` a quarter turn.

        Raises:
            ValueError: if the number of robots changes between calls, or ``facing`` is
                not one move (0..3) a robot.
        """
        here = np.asarray(here, dtype=np.int64)
        goal = np.asarray(goal, dtype=np.int64)
        active = np.asarray(active, dtype=bool)
        facing = None if facing is None else np.asarray(facing, dtype=np.int64)
        if facing is not None and (
            facing.shape != here.shape or ((facing < 0) | (facing > 3)).any()
        ):
            raise ValueError(f"facing must be one move (0..3) a robot, got {facing!r}")
        if len(self._paths.goal) != len(here):
            if len(self._paths.goal):
                raise ValueError("a new fleet needs a new TrafficGuidance")
            self._paths = GuidePaths.empty(len(here))
        self._hold(np.sort(np.asarray([] if held is None else held, dtype=np.int64)))
        limit, batch, share = self.config.time_limit, self.config.search_batch, None
        budget, work = self.config.max_searches, None
        if not self._first:
            if self.config.later_max_searches is not None:
                budget = self.config.later_max_searches
            work = self.config.later_max_expanded
        if self._first and self.config.first_time_limit is not None:
            limit = self.config.first_time_limit
        if self._first and self.config.first_search_batch is not None:
            batch, share = self.config.first_search_batch, FIRST_BATCH_SHARE
        self._first = False
        if limit is not None:
            deadline = min(time.perf_counter() + limit, math.inf if deadline is None else deadline)
        paths = self._paths
        dropped = (paths.goal != goal) | ~active | (self._column[goal] < 0)
        self._drop(np.flatnonzero(dropped & (paths.moves >= 0)))
        paths.goal[:] = np.where(active, goal, -1)
        status = np.ones(len(here), dtype=np.int8)
        column = self._column[here]
        traffic_flow.follow_paths(self._graph, self.flow, paths.pool, paths.start, paths.moves,
                                  paths.cursor, column, self.config.window, self.config.rejoin,
                                  status)  # fmt: skip
        status[~active] = 1
        self._facing = facing
        if facing is not None and not self._lanes_laid:  # a turning fleet: lay its lanes
            self.flow[self._lane_columns, self._lane_moves] += self.config.turn_lane_paths
            self._lay_floor_lanes()
            self._lanes_laid = True
            if self.learner is not None and self.config.learned_lanes_file is not None:
                self.lanes[:] = self._laid_lanes + self.learner.lanes()
        if facing is not None and self.learner is not None and self.learner.observe(column):
            self.lanes[:] = self._laid_lanes + self.learner.lanes()
        self._search_paths(column, status, active, deadline, budget, work, batch, share)
        if share is not None and self.config.search_batch == 1:
            self._searches.close()  # later steps search one at a time: no threads needed
        self._guided = status == 0
        return self._values(here, goal, column, self._guided, distances)

    def _lay_floor_lanes(self) -> None:
        """Lay ``config.floor_lane_paths`` phantom paths along each cell's floor lanes."""
        if not self.config.floor_lane_paths:
            return
        ways = floor_lanes(self._free)
        for axis in range(2):
            cells = np.flatnonzero(ways[:, axis] != NO_LANE)
            self.lanes[cells, ways[cells, axis].astype(np.int64)] = self.config.floor_lane_paths
        self._laid_lanes = self.lanes.copy()

    def cell_values(self, cells: np.ndarray, beside_cost: float = 1.0) -> np.ndarray:
        """The values of any cells along each robot's guide path as of the last
        :meth:`update` (``cells``: ``(N, M)`` cell indices, -1 for none), lower better: a
        cell on the next ``config.window`` cells of the path, the moves left from there;
        a cell beside them, ``beside_cost`` more than the least such; any other,
        ``beside_cost + 1`` more than the moves left from the robot. ``NaN`` for robots
        without a guide path."""
        values = np.full(cells.shape, np.nan)
        robots = np.flatnonzero(self._guided)
        if not robots.size:
            return values
        found = np.empty((robots.size, cells.shape[1]), dtype=np.float64)
        traffic_flow.follow_values(self._paths.pool, self._paths.start, self._paths.moves,
                                   self._paths.cursor, self._cell_row, self._cell_col,
                                   self._column[cells[robots]], robots, self.config.window,
                                   found, float(beside_cost))  # fmt: skip
        worst = self._paths.moves[robots] - self._paths.cursor[robots] + beside_cost + 1
        values[robots] = np.where(np.isinf(found), worst[:, None], found)
        return values

    def _search_paths(
        self,
        column: np.ndarray,
        status: np.ndarray,
        active: np.ndarray,
        deadline: float | None,
        budget: int | None,
        work: int | None,
        batch_size: int,
        batch_share: float | None = None,
    ) -> None:
        """Search the guide paths of the active robots that need one (``status`` 1), then
        refresh ``refresh`` others in turn, in batches of ``batch_size`` (and at most
        ``batch_share`` of the searches, if given), at most ``budget`` searches, no batch
        begun once they have expanded ``work`` cells, and none after ``deadline``;
        ``status`` becomes 0 for every robot that has a guide path after. Where a bound
        leaves robots unsearched, the next step starts with them."""
        n = len(column)
        order = np.roll(np.arange(n), -self._turn)  # who comes first turns round the fleet
        reachable = self._column[self._paths.goal[order]] >= 0
        needed = order[(status[order] == 1) & active[order] & reachable].tolist()
        others = order[(status[order] == 0) & active[order]][: self.config.refresh].tolist()
        self._turn = (self._turn + max(1, self.config.refresh)) % max(n, 1)
        self.searches, self.timed_out, self.expanded = 0, 0, 0
        robots, refreshed = [*needed, *others], set(others)
        if batch_share is not None:
            batch_size = max(1, min(batch_size, int(len(robots) * batch_share)))
        begun = time.perf_counter()
        while self.searches < len(robots):
            if (
                (budget is not None and self.searches >= budget)
                or (work is not None and self.expanded >= work)
                or (deadline is not None and time.perf_counter() > deadline)
            ):
                self.timed_out = max(0, len(needed) - self.searches)
                if self.timed_out:  # the next step starts with the robots left
                    self._turn = robots[self.searches]
                break
            size = batch_size
            if budget is not None:
                size = min(size, budget - self.searches)
            batch = robots[self.searches : self.searches + size]
            tails = self._tails(batch, refreshed)
            self._drop(np.array(batch))
            for i, found in zip(batch, self._search(batch, column, tails), strict=True):
                status[i] = 0 if found else 1
            self.searches += len(batch)
            self.expanded += self._searches.expanded
        self.search_seconds = time.perf_counter() - begun

    def _tails(self, robots: list[int], refreshed: set[int]) -> list[np.ndarray | None]:
        """For each of ``robots``, what its new guide path keeps of its old one: with
        ``config.reroute``, a robot still holding a path with more than twice that many
        cells left past where it stood on it (one pushed off it; a robot with a new goal
        has none) keeps the path's cells from ``reroute`` past that cell on (map
        columns); None for the others, whose paths are searched to their goals, and for
        the robots ``refreshed`` (``refresh``: whole paths searched anew)."""
        reach, paths = self.config.reroute, self._paths
        tails: list[np.ndarray | None] = [None] * len(robots)
        if not reach:
            return tails
        for k, i in enumerate(robots):
            moves, at = paths.moves[i], paths.cursor[i]
            if i not in refreshed and moves >= 0 and moves - at > 2 * reach:
                first = paths.start[i] + at + reach
                tails[k] = paths.pool[first : paths.start[i] + moves + 1].copy()
        return tails

    def _search(
        self, robots: list[int], column: np.ndarray, tails: list[np.ndarray | None]
    ) -> list[bool]:
        """The guide paths of ``robots`` from where they stand (map columns ``column``) to
        their goals, searched as one batch (:mod:`~warehouse_phys.planners.guide_searches`),
        stored and added to the flow in order; for each, False if its goal cannot be
        reached. A robot with a tail (:meth:`_tails`) is searched to the tail's first
        cell, and its path leaves the search's where that first meets the tail (perhaps
        before its end: no cell twice) and goes on along the tail."""
        paths, config = self._paths, self.config
        contraflow = config.contraflow_weight
        if self._facing is not None and config.turn_contraflow_weight is not None:
            contraflow = config.turn_contraflow_weight
        costs = np.array([config.vertex_weight, contraflow, config.heuristic_weight,
                          config.turn_cost or 0.0, config.turn_traffic_weight])  # fmt: skip
        turning = self._facing is not None and config.turn_cost is not None
        facings = [int(self._facing[i]) if turning else -1 for i in robots]
        goals = [int(self._column[paths.goal[i]]) if tail is None else int(tail[0])
                 for i, tail in zip(robots, tails, strict=True)]  # fmt: skip
        sources = [int(column[i]) for i in robots]
        found = self._searches.search(self._graph, self.flow, self.lanes, sources, goals,
                                      facings, costs)  # fmt: skip
        for i, path, tail in zip(robots, found, tails, strict=True):
            if path is None:
                continue
            if tail is not None:  # leave the search's path where it first meets the tail
                meet = int(np.argmax(np.isin(path, tail)))
                path = np.concatenate([path[:meet], tail[int(np.argmax(tail == path[meet])) :]])
            moves = len(path) - 1
            if paths.used + moves + 2 > len(paths.pool):
                paths.compact(moves + 2)
            paths.pool[paths.used] = -1  # free: a robot pushed off the start rejoins there
            paths.pool[paths.used + 1 : paths.used + moves + 2] = path
            paths.start[i], paths.moves[i], paths.cursor[i] = paths.used + 1, moves, 0
            paths.used += moves + 2
            traffic_flow.add_flow(self._graph, self.flow, path, 1)
        return [path is not None for path in found]

    def _drop(self, robots: np.ndarray) -> None:
        """Take the guide paths of ``robots`` away, and what is left of them off the flow."""
        paths = self._paths
        for i in robots.tolist():
            if paths.moves[i] >= 0:
                first = paths.start[i] + paths.cursor[i]
                rest = paths.pool[first : paths.start[i] + paths.moves[i] + 1]
                traffic_flow.add_flow(self._graph, self.flow, rest, -1)
            paths.moves[i] = -1

    def _hold(self, held: np.ndarray) -> None:
        """Make the ``held`` cells walls of the guide paths' graph; when they change, every
        guide path is dropped (to be searched anew round them)."""
        if np.array_equal(held, self._held):
            return
        self._held = held
        self._drop(np.flatnonzero(self._paths.moves >= 0))
        self._graph = self._floor_graph.copy()
        walls = self._column[held]
        walls = walls[walls >= 0]
        if walls.size:
            self._graph[np.isin(self._graph, walls)] = -1
            self._graph[walls] = -1

    def _values(
        self,
        here: np.ndarray,
        goal: np.ndarray,
        column: np.ndarray,
        guided: np.ndarray,
        distances: DistanceMaps | None,
    ) -> np.ndarray:
        """The ``(N, 5)`` candidate values (see :meth:`update`)."""
        values = np.full((len(here), FLEET_ACTIONS), np.nan)
        robots = np.flatnonzero(guided)
        if not robots.size:
            return values
        if self.config.follow:
            return self.cell_values(self._table[here])
        candidates = self._table[here[robots]]
        if distances is None:
            raise ValueError("guidance without following needs the planner's distances")
        targets = np.repeat(goal[robots], FLEET_ACTIONS).reshape(-1, FLEET_ACTIONS)
        distance = distances.lookup(candidates, targets).astype(np.float64)
        from_column = column[robots]
        to_column = self._column[candidates[:, :WAIT]]
        along = self.flow[from_column][:, :WAIT]
        against = self.flow[to_column, [2, 3, 0, 1]]
        share = against / (along + against + 1.0)
        distance[:, :WAIT] += self.config.contraflow_weight * 0.9 * share
        values[robots] = distance
        return values
