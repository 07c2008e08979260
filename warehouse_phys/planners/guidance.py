"""Guided PIBT: PIBT following the guide paths of
:mod:`~warehouse_phys.planners.traffic_guidance`.

:class:`GuidedPIBT` is the planner: the traffic guidance
(:class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance`: guide paths priced
by their own traffic, after Chen, Harabor, Li and Stuckey, AAAI 2024) in front of PIBT's
one-step resolution (the same :class:`~warehouse_phys.planners.pibt.PIBT`, through its
``candidate_values``). For turning robots it can plan over operations
(:mod:`~warehouse_phys.planners.operations`), repair each plan over a window
(:mod:`~warehouse_phys.planners.repair`), and hand a stalled fleet over to one-step PIBT
and back once its jam has cleared (:mod:`~warehouse_phys.planners.pibt.stalls`).
Deterministic for a seed and the same inputs, as long as the guidance's ``time_limit``
is not reached. Like the other rules, it imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.guidance_config import MAX_LANE_PATHS, GuidanceConfig
from warehouse_phys.planners.operations import OperationPIBT
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.planners.pibt.stalls import StallWatch
from warehouse_phys.planners.repair import WindowRepair
from warehouse_phys.planners.traffic_guidance import TrafficGuidance
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES

#: The guidance (``planners.traffic_guidance``) and its configuration
#: (``planners.guidance_config``) still import from here.
__all__ = ["MAX_LANE_PATHS", "GuidanceConfig", "GuidedPIBT", "TrafficGuidance"]


class GuidedPIBT:
    """PIBT following guide paths
    (:class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance`): the planner of
    :func:`warehouse_phys.rl.fleet_planners.guided_pibt_policy`.

    ``plan(cells, goals, movable, present)`` is :meth:`PIBT.plan
    <warehouse_phys.planners.pibt.PIBT.plan>`'s, with the candidates of each robot that
    has a guide path ranked by it; its promises are PIBT's (every plan granted by the
    traffic rule, the same plan for the same seed and inputs), and the guidance's
    bounds hold each step (``config.max_searches``, ``config.time_limit``).

    Args:
        grid: The floor.
        distances: The floor's distance maps (a fleet's ``env.distances``); new by default.
        corner_follows: As :class:`~warehouse_phys.planners.pibt.PIBT`.
        seed: Seeds PIBT's tie-breaks.
        moves: ``"grid"`` or ``"rotate"``, as PIBT.
        config: The guidance's prices, refreshes and bounds.
        operations: Turning robots only: plan with operations of this many actions
            (:class:`~warehouse_phys.planners.operations.OperationPIBT`, its cells valued
            along the guide paths) instead of one-step PIBT; 0 (default): one step.
        repair: Turning robots only: improve each step's plan over a window of
            ``repair_depth`` steps (:class:`~warehouse_phys.planners.repair.WindowRepair`);
            None (default): no repair.
        repair_depth: The repair's window [steps] (its operations' actions, 1..4) where the
            plan is one-step PIBT's; over operations it is theirs.
        hand_over_on_stall: Over operations, plan one step a step, unrepaired, once the
            fleet stalls or stands still (:attr:`stall_watch`: PIBT's swap undoes a jam;
            :meth:`hand_over`), and over operations again, repaired as before, once the
            jam has cleared (:meth:`hand_back`).

    Raises:
        ValueError: for ``operations`` or ``repair`` with four-direction robots, or
            ``operations`` out of 0..4.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        *,
        distances: DistanceMaps | None = None,
        corner_follows: bool = True,
        seed: int = 0,
        moves: str = "grid",
        config: GuidanceConfig | None = None,
        operations: int = 0,
        repair: WindowRepair | None = None,
        repair_depth: int = 3,
        hand_over_on_stall: bool = True,
    ) -> None:
        self.pibt = PIBT(grid, distances=distances, corner_follows=corner_follows, seed=seed,
                         moves=moves)  # fmt: skip
        self.guidance = TrafficGuidance(grid, config)
        for part, given in (("operations are", operations), ("the repair is", repair)):
            if given and moves != "rotate":
                raise ValueError(f"{part} for turning robots (moves='rotate'), got "
                                 f"moves={moves!r}")  # fmt: skip
        #: The planner over operations, if any.
        self.operations: OperationPIBT | None = None
        if operations:
            self.operations = OperationPIBT(grid, distances=self.pibt.distances,
                                            corner_follows=corner_follows, seed=seed,
                                            depth=operations)  # fmt: skip
        #: When the planner over operations hands over (``planners.pibt.stalls``).
        self.stall_watch = StallWatch() if operations and hand_over_on_stall else None
        #: The repair, if any, and the operations it plans one-step PIBT's plans over.
        self.repair = repair
        self._window: OperationPIBT | None = None
        if repair is not None:
            self._window = self.operations or OperationPIBT(
                grid, distances=self.pibt.distances, corner_follows=corner_follows, seed=seed,
                depth=repair_depth)  # fmt: skip
        #: The operations and the repair handed over, while one-step PIBT plans.
        self._handed: tuple[OperationPIBT, WindowRepair | None] | None = None

    def hand_over(self) -> None:
        """Plan one action a step, unrepaired, from the next plan on (a stalled fleet over
        operations: PIBT's swap undoes a jam they cannot; one-step plans repaired jammed
        dense random floors), until the stall watch sees the jam cleared
        (:meth:`hand_back`). The guide paths and PIBT's state carry on. Without
        operations, nothing changes."""
        if self.operations is not None:
            self._handed = (self.operations, self.repair)
            self.operations = self.repair = self._window = None

    def hand_back(self) -> None:
        """Plan over the operations handed over again, repaired as they were, from the
        next plan on."""
        if self._handed is not None:
            (self.operations, self.repair), self._handed = self._handed, None
            self._window = self.operations if self.repair is not None else None

    def drop_operations_and_repair(self) -> None:
        """Plan one action a step from now on, unrepaired (a caller short of time: the
        guide paths and PIBT's state carry on)."""
        self.operations = self.repair = self._window = self._handed = None

    def plan(
        self,
        cells: np.ndarray,
        goals: np.ndarray,
        movable: np.ndarray | None = None,
        present: np.ndarray | None = None,
        *,
        headings: np.ndarray | None = None,
        deadline: float | None = None,
    ) -> np.ndarray:
        """The next joint action, as :meth:`PIBT.plan
        <warehouse_phys.planners.pibt.PIBT.plan>` (``(N,)`` int64), guided; the guide
        paths' searches stop at ``deadline`` (a :func:`time.perf_counter` instant; the
        robots left are PIBT's, and the plan may differ between runs), if given, and so
        does the repair's search, if any
        (:attr:`~warehouse_phys.planners.repair.WindowRepair.deadline`).

        Raises:
            ValueError: as :meth:`PIBT.plan <warehouse_phys.planners.pibt.PIBT.plan>`,
                and if turning robots' ``headings`` are not one of 0..3 each.
        """
        cols = self.pibt.grid.cols
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        goals = np.asarray(goals, dtype=np.int64).reshape(-1, 2)
        n = len(cells)
        present = np.ones(n, dtype=bool) if present is None else np.asarray(present, bool)
        movable = present.copy() if movable is None else np.asarray(movable, bool) & present
        here, goal = cells[:, 0] * cols + cells[:, 1], goals[:, 0] * cols + goals[:, 1]
        facing = None
        if self.pibt.turning and headings is not None:
            headings = np.asarray(headings)
            if headings.shape != (n,) or not np.isin(headings, np.arange(4)).all():
                raise ValueError(f"turning robots need one heading 0..3 each ({n}), got "
                                 f"{headings!r}")  # fmt: skip
            facing = HEADING_MOVES[headings.astype(np.int64)]
        if self.repair is not None:
            self.repair.deadline = deadline
        values = self.guidance.update(here, goal, movable, self.pibt.distances,
                                      here[present & ~movable], facing, deadline)  # fmt: skip
        watch = self.stall_watch
        if self._handed is not None and watch is not None and watch.cleared(here, goal, movable):
            self.hand_back()
        if self.operations is not None:
            # A cell beside the guide path costs more than an operation's moves: a robot
            # leaves its path (and needs a new one) only when no operation along it fits.
            local = self.guidance.cell_values(self.operations.local_cells(here),
                                              beside_cost=self.operations.depth + 1.0)  # fmt: skip
            actions = self.operations.plan(cells, goals, movable, present, headings=headings,
                                           cell_values=local, repair=self.repair)  # fmt: skip
            if watch is not None and watch.observe(actions, movable, here, goal):
                self.hand_over()  # from the next plan on
            return actions
        actions = self.pibt.plan(cells, goals, movable, present, headings=headings,
                                 candidate_values=values)  # fmt: skip
        if self.repair is None or self._window is None:
            return actions
        local = self.guidance.cell_values(self._window.local_cells(here),
                                          beside_cost=self._window.depth + 1.0)  # fmt: skip
        repaired = self._window.improve(cells, goals, movable, present, headings=headings,
                                        actions=actions, repair=self.repair,
                                        cell_values=local)  # fmt: skip
        self.pibt.forget_commitments(np.flatnonzero(repaired != actions))
        return repaired
