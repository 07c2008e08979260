"""A scheduler on true distances: free robots and open tasks paired by a minimum-cost
assignment (LoRR 2024 and later).

The built-in schedulers of :mod:`warehouse_phys.lorr.scheduling` measure a robot's way to
a task in Manhattan moves and pair greedily. :class:`AssignmentScheduler` measures it on
the floor: the fewest moves from the robot's cell to the task's first stop round the
shelves (:class:`~warehouse_phys.planners.distances.DistanceMaps`, a full map per first
stop, so a floor's few pick-up stations cost a few maps), plus ``length_weight`` times
the task's own length (the errand list's ``task_lengths``), and pairs every free robot
with a task at once by a minimum-cost matching over each robot's ``candidates`` cheapest
tasks (SciPy's sparse LAPJV, :func:`~scipy.sparse.csgraph.min_weight_full_bipartite_matching`):
the sum over the robots paired is least, where a greedy pairing lets the first pair
take a task that a second robot needed more. Robots the matching leaves out (when their
candidates are all better used by others, as when a whole fleet is free at the start)
take the cheapest task left by Manhattan makespan (the way plus the weighted length), as
:func:`~warehouse_phys.lorr.scheduling.least_makespan` pairs them, so that every free
robot gets a task while tasks are left.

The length's weight is a choice: 1 pairs by makespan (short tasks first, as the
competition's default entry does), which finishes more early on but leaves the long tasks
to pile up among the open ones, so that later robots find fewer near them; 0 pairs by
the way to the first stop alone. What it does not know: where other robots will be
(traffic), nor a robot's heading (a turn or two at its start).

Deterministic: the same robots and tasks give the same pairs. Like
:mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk nor
pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.lorr.scheduling import (
    SCHEDULERS,
    Scheduler,
    _greedy_pairs,
    _points,
    scheduler_named,
)
from warehouse_phys.lorr.station_cap import STATION_CAP, check_cap
from warehouse_phys.planners.distances import UNREACHABLE, DistanceMaps
from warehouse_phys.world.grid import WarehouseGrid

#: Open tasks each free robot may be paired with: its cheapest by Manhattan makespan.
CANDIDATES = 32
#: The weight of a task's own length in its cost by default (see the module).
LENGTH_WEIGHT = 0.5
#: Most memory the scheduler's distance maps may hold [bytes].
MAX_BYTES = 256 * 2**20
#: The matching's unit of cost: 1/QUANTUM of a move. Costs are matched as whole numbers of
#: it, because SciPy's LAPJVsp can loop forever on fractional costs (seen with SciPy 1.17:
#: an 8 x 8 matching with a length weight of 0.31 never returned); whole numbers below
#: 2**53 are exact, and a pairing's total is then at most robots/QUANTUM/2 moves from
#: the least.
QUANTUM = 1024
#: The largest ``length_weight`` taken: a task's length weighed a thousand times the way
#: to it is past any use, and it keeps every cost a whole number below 2**53 (a floor's
#: longest distance, 2,048 x 2,048 cells, times the weight times QUANTUM).
MAX_LENGTH_WEIGHT = 1000.0


class AssignmentScheduler:
    """A :data:`~warehouse_phys.lorr.scheduling.Scheduler` pairing free robots and open
    tasks by a minimum-cost matching on true distances (the module's docstring).

    Args:
        grid: The floor.
        length_weight: The weight of a task's own length in its cost (0 to
            :data:`MAX_LENGTH_WEIGHT`).
        candidates: Cheapest open tasks each robot may be paired with (>= 1).
        distances: Distance maps of the floor (new, of at most :data:`MAX_BYTES`, by
            default).
        rematch: Ask the errand list to pair again, with the free robots, the robots on
            their way to a task not opened yet (:attr:`rematch`,
            :mod:`warehouse_phys.lorr.rematching`): ``"rematch"`` by name.
        station_cap: Ask the errand list to offer the pairing no task whose first stop
            already has this many robots on their way (:attr:`station_cap`,
            :mod:`warehouse_phys.lorr.station_cap`); None (default): no cap.
            ``"rematch-capped"`` by name rematches with a cap of
            :data:`~warehouse_phys.lorr.station_cap.STATION_CAP`.
        cap_follows_backlog: Let each first stop's cap grow with its open tasks
            (:attr:`cap_follows_backlog`, :func:`~warehouse_phys.lorr.station_cap.stop_caps`):
            ``"rematch-backlog"`` by name, with a ``station_cap`` of
            :data:`~warehouse_phys.lorr.station_cap.STATION_CAP`.

    Raises:
        ValueError: for a weight below 0 or not finite, no candidates, a
            ``station_cap`` below 1, or ``cap_follows_backlog`` without a ``station_cap``.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        *,
        length_weight: float = LENGTH_WEIGHT,
        candidates: int = CANDIDATES,
        distances: DistanceMaps | None = None,
        rematch: bool = False,
        station_cap: int | None = None,
        cap_follows_backlog: bool = False,
    ) -> None:
        if not 0 <= length_weight <= MAX_LENGTH_WEIGHT or candidates < 1:
            raise ValueError(f"length_weight must be 0 to {MAX_LENGTH_WEIGHT:g} and candidates "
                             f">= 1, got {length_weight!r} and {candidates!r}")  # fmt: skip
        self.grid = grid
        self.length_weight = float(length_weight)
        self.candidates = int(candidates)
        self.distances = distances or DistanceMaps(grid, max_bytes=MAX_BYTES)
        #: Whether the errand list (:class:`~warehouse_phys.lorr.errands.ScheduledTasks`)
        #: hands it, each step, the robots on their way to a task not opened yet with the
        #: free ones (their tasks back among the open ones).
        self.rematch = bool(rematch)
        #: The most robots on their way to one first stop that the errand list lets the
        #: pairing make (None: no cap).
        self.station_cap = None if station_cap is None else check_cap(station_cap)
        if cap_follows_backlog and self.station_cap is None:
            raise ValueError("cap_follows_backlog needs a station_cap")
        #: Whether each first stop's cap grows with its open tasks
        #: (:func:`~warehouse_phys.lorr.station_cap.stop_caps`).
        self.cap_follows_backlog = bool(cap_follows_backlog)
        self.__name__ = "rematch" if self.rematch else "assignment"
        if self.station_cap is not None:
            self.__name__ += "-backlog" if self.cap_follows_backlog else "-capped"

    def __call__(
        self,
        robot_cells: np.ndarray,
        task_cells: np.ndarray,
        cols: int,
        *,
        task_lengths: np.ndarray | None = None,
    ) -> np.ndarray:
        """For each free robot (``robot_cells``) the position in ``task_cells`` of the
        task it takes, -1 for none (the scheduler interface)."""
        robot_cells = np.asarray(robot_cells, dtype=np.int64)
        task_cells = np.asarray(task_cells, dtype=np.int64)
        lengths = np.zeros(len(task_cells)) if task_lengths is None else task_lengths
        lengths = np.asarray(lengths, dtype=np.float64) * self.length_weight
        choice = np.full(len(robot_cells), -1, dtype=np.int64)
        if not len(robot_cells) or not len(task_cells):
            return choice
        # SciPy's sparse graphs here: 0.3 s to import, for the fleets that schedule.
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import min_weight_full_bipartite_matching

        robots, tasks, cost = self._candidate_costs(robot_cells, task_cells, lengths, cols)
        whole = np.rint(cost * QUANTUM) + QUANTUM  # > 0: a zero would be no edge at all
        graph = csr_matrix((whole, (robots, tasks)),
                           shape=(len(robot_cells), len(task_cells)))  # fmt: skip
        try:
            rows, columns = min_weight_full_bipartite_matching(graph)
            choice[rows] = columns
        except ValueError:  # no matching pairs every robot among its candidates: greedily
            order = np.lexsort((tasks, robots, cost))
            taken = np.zeros(len(task_cells), dtype=bool)
            for robot, task in zip(robots[order].tolist(), tasks[order].tolist(), strict=True):
                if choice[robot] < 0 and not taken[task]:
                    choice[robot], taken[task] = task, True
        left = np.flatnonzero(choice < 0)
        free = np.setdiff1d(np.arange(len(task_cells)), choice[choice >= 0])
        if left.size and free.size:  # by Manhattan makespan, as least_makespan pairs them
            robot_at = np.column_stack([_points(robot_cells[left], cols), np.zeros(left.size)])
            task_at = np.column_stack([_points(task_cells[free], cols), lengths[free]])
            picked = _greedy_pairs(robot_at, task_at)
            choice[left[picked >= 0]] = free[picked[picked >= 0]]
        return choice

    def _candidate_costs(
        self, robot_cells: np.ndarray, task_cells: np.ndarray, lengths: np.ndarray, cols: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each robot's cheapest tasks by Manhattan makespan (a k-d tree), and each such
        pair's cost on the floor: ``(robots, tasks, costs)``, a pair a position."""
        from scipy.spatial import cKDTree  # here, as the matching's SciPy (above)

        k = min(self.candidates, len(task_cells))
        robot_at = np.column_stack([_points(robot_cells, cols), np.zeros(len(robot_cells))])
        task_at = np.column_stack([_points(task_cells, cols), lengths])
        _, nearest = cKDTree(task_at).query(robot_at, k=k, p=1)
        tasks = np.asarray(nearest, dtype=np.int64).reshape(len(robot_cells), k).ravel()
        robots = np.repeat(np.arange(len(robot_cells)), k)
        way = self.distances.lookup(robot_cells[robots], task_cells[tasks]).astype(np.float64)
        reachable = way < UNREACHABLE
        cost = way + lengths[tasks]
        return robots[reachable], tasks[reachable], cost[reachable]


#: The name of the scheduler an instance's fleet uses unless given one.
DEFAULT_SCHEDULER = "rematch"


def default_scheduler(grid: WarehouseGrid) -> AssignmentScheduler:
    """The scheduler an instance's fleet on ``grid`` uses unless given one
    (:data:`DEFAULT_SCHEDULER`): the assignment on true distances, rematching robots on
    their way to a task not opened yet. With guided PIBT and turning robots it finished
    more tasks than the nearest pairing, the makespan pairing and the plain assignment on
    each of the 2024 main round's five random floors (3.5-11 % more than the next best,
    5-26 % more than the nearest), and on 2024 WAREHOUSE more than the makespan pairing
    over 300 steps and the assignment over 2,000 (``docs/lorr.md``)."""
    return AssignmentScheduler(grid, rematch=True)


#: Every scheduler's name: the built-in ones, ``"assignment"`` (:class:`AssignmentScheduler`),
#: ``"rematch"`` (the same, rematching: :attr:`AssignmentScheduler.rematch`),
#: ``"rematch-capped"`` (rematching, at most
#: :data:`~warehouse_phys.lorr.station_cap.STATION_CAP` robots on their way to one first
#: stop: :attr:`AssignmentScheduler.station_cap`) and ``"rematch-backlog"`` (the same cap,
#: growing at a stop with more open tasks than the mean stop:
#: :attr:`AssignmentScheduler.cap_follows_backlog`).
SCHEDULER_NAMES = (*SCHEDULERS, "assignment", "rematch", "rematch-capped", "rematch-backlog")
#: The names of :data:`SCHEDULER_NAMES` that are an :class:`AssignmentScheduler`.
_ASSIGNMENTS = SCHEDULER_NAMES[len(SCHEDULERS) :]


def scheduler_for(name: str, grid: WarehouseGrid) -> Scheduler:
    """The scheduler called ``name`` (of :data:`SCHEDULER_NAMES`; ``assignment=W``,
    ``rematch=W``, ``rematch-capped=W`` and ``rematch-backlog=W`` take ``length_weight``
    W) for a fleet on ``grid``.

    Raises:
        ValueError: naming the known schedulers, for another name.
    """
    kind, equals, weight = name.partition("=")
    if kind in _ASSIGNMENTS:
        try:
            weighed = {"length_weight": float(weight)} if equals else {}
            cap = STATION_CAP if kind in ("rematch-capped", "rematch-backlog") else None
            return AssignmentScheduler(grid, rematch=kind != "assignment", station_cap=cap,
                                       cap_follows_backlog=kind == "rematch-backlog",
                                       **weighed)  # fmt: skip
        except ValueError:
            raise ValueError(
                f"{kind}=W needs a weight W from 0 to {MAX_LENGTH_WEIGHT:g}, got {name!r}"
            ) from None
    if name not in SCHEDULERS:
        raise ValueError(f"unknown scheduler {name!r}; known: {', '.join(SCHEDULER_NAMES)}")
    return scheduler_named(name)
