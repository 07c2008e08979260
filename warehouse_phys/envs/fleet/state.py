"""A fleet's robots as arrays: where each stands and faces, what it carries, whether it
parked or left, what it delivered; their read-only views, and the bookkeeping of
placement at a reset and of deliveries (packages drawn or an instance's errands).

:class:`FleetState` is the part of :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`
that holds this state: the environment sets the floor and placement it reads (the
attributes annotated below) and calls ``FleetState._place_robots`` at every reset
and ``FleetState._deliver`` after every step's moves. Planners and evaluators read
the views (:attr:`~FleetState.robot_cells`, :attr:`~FleetState.package_cells`, ...),
never the arrays behind them.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.lorr.errands import ErrandList
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import Heading
from warehouse_phys.world.placement import draw_new_packages, draw_placement

__all__ = ["FleetState", "read_only"]


def read_only(array: np.ndarray) -> np.ndarray:
    """A read-only view of ``array`` (the array itself stays writeable)."""
    view = array.view()
    view.flags.writeable = False
    return view


class FleetState:
    """The state of a fleet's robots, kept as arrays, and its read-only views.

    A base class of :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`, which sets
    the attributes annotated here before it calls ``_init_state``.
    """

    grid: WarehouseGrid
    num_robots: int
    moves: str  # "grid" or "rotate"
    on_delivery: str  # "park", "leave" or "new_package"
    np_random: np.random.Generator
    _track_gaps: bool
    #: Where packages may be drawn and robots may stand, as cell indices (``row * cols + col``).
    _targets: np.ndarray
    _reachable: np.ndarray
    #: The start cells of ``starts="layout"`` (an instance's starts); ``None`` when drawn.
    _layout_starts_index: np.ndarray | None
    _errands: ErrandList | None

    def _init_state(self) -> None:
        """The arrays of ``num_robots`` robots, before their first reset."""
        n = self.num_robots
        self._cells = np.zeros((n, 2), dtype=np.int64)  # and _here, as indices
        self._packages = np.zeros((n, 2), dtype=np.int64)  # and _package_index
        self._headings = np.zeros(n, dtype=np.int64) if self.turning else None
        self._every_robot = read_only(np.arange(n))
        self._parked = np.zeros(n, dtype=bool)
        self._on_floor = np.ones(n, dtype=bool)
        self._deliveries = np.zeros(n, dtype=np.int64)
        self._steps = 0
        self._distances: DistanceMaps | None = None

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
        return read_only(self._cells)

    @property
    def robot_headings(self) -> np.ndarray | None:
        """Each turning robot's heading (:class:`~warehouse_phys.world.headings.Heading`),
        ``(N,)`` int64, read-only; ``None`` for robots that do not turn."""
        return None if self._headings is None else read_only(self._headings)

    @property
    def package_cells(self) -> np.ndarray:
        """Each robot's package ``(row, col)``, ``(N, 2)`` int64, read-only (an instance
        fleet: its next errand; its own cell for a robot without one)."""
        return read_only(self._packages)

    @property
    def errands(self) -> ErrandList | None:
        """An instance fleet's errand list (errands and tasks finished, events);
        ``None`` for a fleet that draws its packages."""
        return self._errands

    @property
    def parked(self) -> np.ndarray:
        """Which robots are parked on their delivered package (``on_delivery="park"``)."""
        return read_only(self._parked)

    @property
    def on_floor(self) -> np.ndarray:
        """Which robots are on the floor (all but those that left, ``on_delivery="leave"``)."""
        return read_only(self._on_floor)

    @property
    def deliveries(self) -> np.ndarray:
        """Packages each robot delivered (an instance fleet: errands it finished) this
        episode, ``(N,)`` int64, read-only."""
        return read_only(self._deliveries)

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

    # ------------------------------------------------------------ the bookkeeping
    def _place_robots(self) -> None:
        """Every robot on a start cell with a new package (an instance fleet: its first
        errand), drawn with ``np_random``; nothing parked, nothing delivered."""
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
        self._parked[:] = False
        self._on_floor[:] = True
        self._deliveries[:] = 0
        self._steps = 0

    def _deliver(self, moved: np.ndarray, live: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The deliveries of a step whose robots now stand on ``moved`` (cell indices, the
        robots' ``_here``): ``(arrived, delivered)``, which robots reached their package
        (``(N,)`` bool) and their indices.

        A robot that delivered counts it, and gets its next errand (an instance fleet), a
        new package (``"new_package"``), or parks or leaves the floor. ``live``: the
        robots still in the episode (the parked and the gone deliver no more).
        """
        cols = self.grid.cols
        arrived = moved == self._package_index
        if self._errands is not None:
            arrived &= self._errands.goals >= 0
        elif len(live) < self.num_robots:  # the parked and the gone deliver no more
            still = np.zeros(self.num_robots, dtype=bool)
            still[live] = True  # a mask: np.isin's sort costs more on a small fleet's step
            arrived &= still
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
        return arrived, delivered

    def _draw_new_packages(self, robots: np.ndarray) -> None:
        """New packages for ``robots``, as
        :func:`~warehouse_phys.world.placement.draw_new_packages` draws them."""
        if not robots.size:
            return
        cells = draw_new_packages(self.np_random, self._targets, self.grid.rows * self.grid.cols,
                                  self._here, self._package_index, robots)  # fmt: skip
        self._packages[robots, 0], self._packages[robots, 1] = np.divmod(cells, self.grid.cols)
        self._package_index[robots] = cells
