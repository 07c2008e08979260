"""The entry's planner: a window of lock-step steps for turning robots, planned from where
the start kit predicts the robots will stand, by the package's planner.

The start kit asks its planner, every ``planCommTimeLimit``, for actions that start where
each robot stands once its staged actions are done (its *predicted state*), and runs them
after those. :class:`EntryPlanner` plans ``steps`` joint steps from there with
one of :data:`ENTRY_PLANNERS`, each step from the last:

- ``"guided-ops-repair"`` (the entry's): :class:`~warehouse_phys.planners.guidance.GuidedPIBT`
  over operations of :data:`ENTRY_OPERATIONS` actions, each step's plan improved by the
  windowed repair (:class:`~warehouse_phys.planners.repair.WindowRepair`,
  :data:`ENTRY_REPAIR`), as the ``guided-ops-repair`` of
  :mod:`warehouse_phys.rl.fleet_planners` but without its lanes over the whole floor;
- ``"guided"``: guided PIBT, one action a step (PIBT over cells and headings following
  traffic-priced guide paths, with one-way lanes in narrow corridors);
- ``"pibt"``: plain :class:`~warehouse_phys.planners.pibt.PIBT`;

and holds every rotation (the kit's square robots cannot rotate:
:func:`~warehouse_phys.execution.windows.without_rotations`). Actions are the kit's
numbers, which are :class:`~warehouse_phys.world.headings.TurnAction`'s: forward 0,
clockwise 1, counter-clockwise 2, wait 3.

:func:`goals_after_queue` is the goal each robot should plan for: the kit counts an errand
on the tick a robot stands on it, so a robot whose staged actions pass its next errand has
done it by the time the plan starts, and plans for the one after (or for none, its task
done). Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium,
pymunk nor pygame.
"""

from __future__ import annotations

import dataclasses
import gc
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Any

import numpy as np

from warehouse_phys.execution.plan_checks import NO_ROBOT, rows_cols
from warehouse_phys.execution.ticks import check_whole
from warehouse_phys.execution.windows import REPLANS, rotation_heads, without_rotations
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.guidance_config import GuidanceConfig, default_workers
from warehouse_phys.planners.named import named_planner, planner_setup, split_guidance
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, TurnAction, turned
from warehouse_phys.world.traffic import neighbour_table

#: The planners an entry may use, by name (the best first; the module).
ENTRY_PLANNERS = ("guided-ops-repair", "guided", "pibt")
#: Actions in an operation of ``"guided-ops-repair"`` (its repair's window) [steps].
ENTRY_OPERATIONS = 3
#: ``"guided-ops-repair"``'s repair (:class:`~warehouse_phys.planners.repair.WindowRepair`'s
#: arguments). By the kit's rules (:mod:`~warehouse_phys.lorr.startkit.system`, 600 ticks,
#: delay seeds 0-11, the scheduler pairing again) random-example_400 finished 532.8 tasks
#: on average against guided PIBT's 522.3, and maze-example_40 86.5 against 82.3 (seeds
#: 0-5); 16 robots a neighbourhood gave 533.6, within the seeds' spread, and the lanes
#: over the whole floor of :mod:`~warehouse_phys.rl.fleet_planners` 501.0 (they suit
#: warehouse aisles, not a random floor). In the kit the plan's time bound bounds the
#: repair too.
ENTRY_REPAIR: dict[str, int] = {"neighbourhood": 8, "iterations": 2000}
#: Bounded plans in a row whose work besides the guide-path searches and the repair took
#: longer than the whole bound before ``"guided-ops-repair"`` drops its operations and its
#: repair and plans one action a step (as ``"guided"``): at 10,000 robots on this 2-core
#: machine its operations alone take about 0.5 s a step, and a round of the kit's 1 s
#: holds three or four steps; at 2,500 robots the whole plan takes 0.2-0.6 s unbounded.
OVERRUNS_TO_LIGHTEN = 2
#: Most steps a window may hold.
MAX_STEPS = 64
#: The guided planners' guidance in the entry: the package's defaults but lighter prices
#: on traffic, for every map: a move into a cell that other guide paths leave costs 0.25
#: a path (``vertex_weight``, 0.5 by default), a turn there 0.25 (``turn_traffic_weight``,
#: 0.5). By the kit's rules (:mod:`~warehouse_phys.lorr.startkit.system`, 600 ticks),
#: over delay seeds 0-11, ``"guided-ops-repair"`` with the scheduler pairing again
#: finished 537.4 tasks on random-example_400 with the weight 0.25, against 528.3 (0.5),
#: 532.8 (0.1) and 529.6 (0.05), and 86.5 on maze-example_40 against 86.2 (0.5) and 87.3
#: (0.1); the turns' 0.5 gave 529.5 (with 0.1). One-step guided PIBT with the first
#: scheduler (delay seeds 0-5): 504.8 (0.25), 505.7 (0.1), 497.2 (0.5), 488.7 (0);
#: lighter weights also halve the cells the guide-path searches expand.
ENTRY_GUIDANCE = GuidanceConfig(vertex_weight=0.25, turn_traffic_weight=0.25)
#: Plans in a row a robot with an errand elsewhere may start on one cell before it is
#: taken for stuck (about :data:`STUCK_PLANS` rounds of the kit's).
STUCK_PLANS = 5
#: Plans a stuck robot heads for a detour, and how far the detour may be [cells].
DETOUR_PLANS, DETOUR_RADIUS = 2, 4


def entry_planner(
    name: str, grid: WarehouseGrid, seed: int = 0, guidance: Mapping[str, Any] | None = None
) -> GuidedPIBT | PIBT:
    """The planner called ``name`` for turning robots on ``grid``, seeded: one of
    :data:`ENTRY_PLANNERS`, set for the entry (the module), or any other of
    :data:`~warehouse_phys.planners.named.PLANNERS` as
    :func:`~warehouse_phys.planners.named.named_planner` makes it. ``guidance`` sets
    fields of a guided planner's guidance and repair over the entry's own
    (:func:`~warehouse_phys.planners.named.split_guidance`: ``{"reroute": 32}``, say).

    Raises:
        ValueError: for another name, guidance given to plain PIBT, or a field's value
            the guidance or the repair refuses.
        TypeError: naming a field the planner lacks.
    """
    guidance = dict(guidance or {})
    if name in ("guided-ops-repair", "guided"):
        fields, repair = split_guidance(name, guidance)
        # The cores are counted now, not when ENTRY_GUIDANCE was made at import.
        config = dataclasses.replace(ENTRY_GUIDANCE, **{"workers": default_workers(), **fields})
        if name == "guided":
            return GuidedPIBT(grid, seed=seed, moves="rotate", config=config)
        return GuidedPIBT(grid, seed=seed, moves="rotate", config=config,
                          operations=ENTRY_OPERATIONS,
                          repair=WindowRepair(**(ENTRY_REPAIR | repair), seed=seed))  # fmt: skip
    if name == "pibt":
        planner_setup(name, **guidance)  # refuses any guidance
        return PIBT(grid, seed=seed, moves="rotate")
    return named_planner(name, grid, moves="rotate", seed=seed, **guidance)


class EntryPlanner:
    """Windows of ``steps`` joint steps for a fleet of turning robots (see the module).

    Args:
        grid: The floor.
        steps: Steps a window holds (1 to :data:`MAX_STEPS`).
        planner: One of :data:`ENTRY_PLANNERS`.
        seed: The planner's seed: the same seed and inputs give the same windows (the
            guided planner's time bound, if any, aside).
        guidance: Fields of the guided planner's guidance and repair
            (:func:`entry_planner`; None: the entry's own).

    Raises:
        ValueError, TypeError: naming the argument.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        *,
        steps: int,
        planner: str = ENTRY_PLANNERS[0],
        seed: int = 0,
        guidance: Mapping[str, Any] | None = None,
    ) -> None:
        self.grid = grid
        self.steps = check_whole("steps", steps, 1, MAX_STEPS)
        self.name = planner
        self.planner = entry_planner(planner, grid, seed, guidance)
        table = neighbour_table(grid)
        #: ``(cells, 4)`` the cell a forward move along each heading enters.
        self.ahead = table[:, HEADING_MOVES]
        self._occupant = np.full(grid.rows * grid.cols, NO_ROBOT, dtype=np.int64)
        self._rng = np.random.default_rng(seed)
        self._free = grid.reachable_mask.reshape(-1)
        self._last = np.zeros(0, dtype=np.int64)
        self._still = np.zeros(0, dtype=np.int64)
        self._detour = np.zeros(0, dtype=np.int64)
        self._left = np.zeros(0, dtype=np.int64)
        self._other = 0.0  # a step's time besides its guide-path searches [s]
        self._overruns = 0
        #: Whether the planner dropped its operations and repair to keep to its bound.
        self.lightened = False

    def plan(
        self, cells: np.ndarray, headings: np.ndarray, goals: np.ndarray,
        steps: int | None = None, *, seconds: float | None = None,
    ) -> np.ndarray:  # fmt: skip
        """``(N, steps)`` int64: each robot's actions from ``cells`` (``(N,)`` cell indices)
        and ``headings`` (``(N,)`` 0..3) towards ``goals`` (``(N,)`` cell indices, -1: no
        errand, the robot keeps its cell unless pushed), ``steps`` of them (0 to
        :data:`MAX_STEPS`; default :attr:`steps`). No step rotates robots.

        ``seconds`` bounds the guided planner's guide-path searches so that the plan takes
        about that long [s, wall clock] (``_deadline``; the start kit's rounds are
        real time): robots left without a guide path step by PIBT's distances, and the
        plan may differ between runs. ``None`` (default): no bound, the same plan for the
        same inputs.

        ``"guided-ops-repair"`` planning :data:`OVERRUNS_TO_LIGHTEN` bounded plans in a row
        whose work besides its searches and repair alone takes longer than ``seconds``
        plans one action a step from then on (:attr:`lightened`).

        A robot that starts :data:`STUCK_PLANS` plans in a row on the same cell, an errand
        elsewhere, is stuck (PIBT for turning robots, which may not rotate here, locks a
        crowd in a narrow loop now and then: the maze example locked within 2,000 ticks on
        each of 3 delay seeds without this, never with it): for
        :data:`DETOUR_PLANS` plans it heads for a free cell drawn within
        :data:`DETOUR_RADIUS` cells instead, which frees room for the others.

        Raises:
            ValueError: as the planner refuses its inputs (a fleet of another size than the
                last call's, headings out of 0..3).
        """
        end = None if seconds is None else time.perf_counter() + float(seconds)
        here = np.asarray(cells, dtype=np.int64).copy()
        facing = np.asarray(headings, dtype=np.int64).copy()
        goals = self._detoured(here, np.asarray(goals, dtype=np.int64))
        steps = self.steps if steps is None else check_whole("steps", steps, 0, MAX_STEPS)
        actions = np.empty((len(here), steps), dtype=np.int64)
        fixed = 0.0  # the plan's work besides its searches and repair [s]
        with collector_paused():
            for s in range(steps):
                step, kept = self._step(here, facing, goals, self._deadline(end, steps - s))
                actions[:, s] = step
                facing = turned(facing, step)
                here = kept
                fixed += self._other
        if seconds is not None:
            self._lighten_after(fixed > seconds)
        return actions

    def _lighten_after(self, overran: bool) -> None:
        """Count a bounded plan that ``overran`` its bound without its searches and repair;
        after :data:`OVERRUNS_TO_LIGHTEN` in a row, drop the operations and the repair."""
        self._overruns = self._overruns + 1 if overran else 0
        planner = self.planner
        if (self._overruns >= OVERRUNS_TO_LIGHTEN and isinstance(planner, GuidedPIBT)
                and planner.operations is not None):  # fmt: skip
            planner.drop_operations_and_repair()
            self.lightened = True

    def _deadline(self, end: float | None, steps_left: int) -> float | None:
        """When this step's guide-path searches stop for the plan to end at ``end``: an
        equal share of the time left a step, less what the last step spent besides its
        searches (PIBT's own work)."""
        if end is None or not isinstance(self.planner, GuidedPIBT):
            return None
        now = time.perf_counter()
        return now + (end - now) / steps_left - self._other

    @property
    def detours(self) -> np.ndarray:
        """``(N,)`` the cell each robot heads for instead of its errand, stuck (-1 none)."""
        return np.where(self._left > 0, self._detour, -1)

    def _detoured(self, here: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """``goals`` with the stuck robots' detours in (see :meth:`plan`)."""
        n = len(here)
        if len(self._last) != n:
            self._last, self._still = here.copy(), np.zeros(n, dtype=np.int64)
            self._detour, self._left = np.full(n, -1, dtype=np.int64), np.zeros(n, np.int64)
        unmoved = (here == self._last) & (goals >= 0) & (goals != here)
        self._still = np.where(unmoved, self._still + 1, 0)
        self._last = here.copy()
        stuck = np.flatnonzero((self._still >= STUCK_PLANS) & (self._left == 0))
        if stuck.size:
            self._detour[stuck] = self._near(here[stuck])
            self._left[stuck] = DETOUR_PLANS
            self._still[stuck] = 0
        active = self._left > 0
        self._left[active] -= 1
        return np.where(active & (self._detour >= 0), self._detour, goals)

    def _near(self, cells: np.ndarray) -> np.ndarray:
        """A reachable cell within :data:`DETOUR_RADIUS` of each of ``cells`` (-1 where a
        few draws find none)."""
        cols, rows = self.grid.cols, self.grid.rows
        row, col = np.divmod(cells, cols)
        found = np.full(len(cells), -1, dtype=np.int64)
        for _ in range(8):
            d_row, d_col = self._rng.integers(-DETOUR_RADIUS, DETOUR_RADIUS + 1, (2, len(cells)))
            r, c = row + d_row, col + d_col
            inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
            cell = np.where(inside, r * cols + c, 0)
            ok = inside & self._free[cell] & (cell != cells) & (found < 0)
            found[ok] = cell[ok]
        return found

    def _step(
        self, here: np.ndarray, facing: np.ndarray, goals: np.ndarray, deadline: float | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """One joint step without rotations: its actions and the cells they lead to. A
        step with rotations is planned again with one robot of each (the lowest-numbered)
        aiming at its own cell, so that it stays and the others go round it (up to
        :data:`~warehouse_phys.execution.windows.REPLANS` times); rotations left are held
        (:func:`~warehouse_phys.execution.windows.without_rotations`)."""
        cols = self.grid.cols
        aims = np.where(goals >= 0, goals, here)
        other = 0.0  # what the step spends besides its searches and repair, every attempt [s]
        for attempt in range(REPLANS + 1):
            begun = time.perf_counter()
            bound = {} if deadline is None else {"deadline": deadline}
            step = self.planner.plan(rows_cols(here, cols), rows_cols(aims, cols),
                                     headings=facing, **bound)  # fmt: skip
            if deadline is not None:
                repair = self.planner.repair  # (the repair takes what time is left)
                other += (time.perf_counter() - begun - self.planner.guidance.search_seconds
                          - (0.0 if repair is None else repair.stats.seconds))  # fmt: skip
                self._other = other
            forward = step == TurnAction.FORWARD
            wanted = np.where(forward, self.ahead[here, facing], here)
            heads = rotation_heads(here, wanted, self._occupant)
            if not len(heads) or attempt == REPLANS:
                break
            aims[heads] = here[heads]
        kept = without_rotations(here, wanted, self._occupant)
        return np.where(forward & (kept != wanted), TurnAction.WAIT, step), kept


class _CollectorPauses:
    """How many calls hold the collector off, across threads (the kit runs its planner in
    a thread of its own while its main thread calls the executor), and whether it was on
    when the first of them began."""

    lock = threading.Lock()
    holders = 0
    was_enabled = False


@contextmanager
def collector_paused() -> Iterator[None]:
    """Python's cycle collector held off for a while: a plan builds a list a robot a step
    (PIBT's candidates) and no cycles, so at 10,000 robots the collector's passes over
    the whole heap took a tenth of a plan for nothing. Calls may overlap, in one thread or
    several: the collector stays off until the last of them ends, and is then as it was
    before the first began."""
    pauses = _CollectorPauses
    with pauses.lock:
        if pauses.holders == 0:
            pauses.was_enabled = gc.isenabled()
            gc.disable()
        pauses.holders += 1
    try:
        yield
    finally:
        with pauses.lock:
            pauses.holders -= 1
            if pauses.holders == 0 and pauses.was_enabled:
                gc.enable()


def goals_after_queue(queue_cells: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """``(N,)`` each robot's next errand once its staged actions are done: the first of its
    task's remaining ``stops`` (``(N, M)`` cell indices in order, padded with -1; all -1
    for a robot without a task) that the robot does not stand on, in turn, along
    ``queue_cells`` (``(N, W + 1)``: where it stands now, then after each staged action);
    -1 for a robot whose task is done by then."""
    stops = np.asarray(stops, dtype=np.int64)
    queue_cells = np.asarray(queue_cells, dtype=np.int64)
    n, m = stops.shape
    if not m:
        return np.full(n, -1, dtype=np.int64)
    robots = np.arange(n)
    done = np.zeros(n, dtype=np.int64)
    for cells in queue_cells.T:  # one errand a tick at most: one a queued cell
        nxt = stops[robots, np.minimum(done, m - 1)]
        done += (done < m) & (nxt >= 0) & (cells == nxt)
    return np.where(done < m, stops[robots, np.minimum(done, m - 1)], -1)


def with_held(stops: np.ndarray, held_stop: np.ndarray) -> np.ndarray:
    """``stops`` (``(N, M)``, padded with -1) with each robot's ``held_stop`` (``(N,)``: the
    first errand of the task held for it, -1 none) after its last: ``(N, M + 1)``."""
    stops = np.asarray(stops, dtype=np.int64)
    count = (stops >= 0).sum(axis=1)
    joined = np.concatenate([stops, np.full((len(stops), 1), -1, dtype=np.int64)], axis=1)
    holding = np.flatnonzero(np.asarray(held_stop) >= 0)
    joined[holding, count[holding]] = np.asarray(held_stop)[holding]
    return joined
