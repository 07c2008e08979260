"""A fleet's plans executed tick by tick: ticks, delays, the executor and the planner, composed.

:class:`Execution` is what a fleet environment, ``simulate`` and the benchmarks run
when moves take ticks (League of Robot Runners 2026): each robot's move takes
:func:`~warehouse_phys.execution.ticks.move_ticks` ticks, delays are drawn a tick at a time
(:class:`~warehouse_phys.execution.delays.DelayGenerator`), a PIBT window is planned every
``plan_every`` ticks from where the robots' current moves end, and the
:class:`~warehouse_phys.execution.executor.Executor` says GO or STOP to every robot every
tick. The caller gives the goals (its errands) and may *hold* robots (an RL agent's
STOP): a held robot does not advance, exactly as if it were delayed, so the executor's
guarantees (no conflict, no deadlock once holds end) stand whatever the caller does.

It keeps the measures of point 4 of the asynchronous execution (:class:`ExecutionMeasures`):
robot-ticks stood still by a robot's own delay, by knock-on delay (a robot ahead had
not moved on), by the caller's holds, and the drift from the plan. Nothing here knows
errands or bodies: the caller counts errands on the moves that ended
(:attr:`TickOutcome.report`), and the physics twin drives its bodies from the same
report. Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium,
pymunk nor pygame.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.execution.delays import DelayConfig, DelayGenerator
from warehouse_phys.execution.executor import Executor, TickReport
from warehouse_phys.execution.following import DEFAULT_MIN_GAP
from warehouse_phys.execution.ticks import check_ticks_per_move, check_whole, move_ticks
from warehouse_phys.execution.windows import pibt_window, window_planner
from warehouse_phys.planners.guidance import GuidedPIBT
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import TurnAction
from warehouse_phys.world.traffic import WAIT

#: Most steps one planned window may hold.
MAX_WINDOW = 64
#: How the windows may treat robots that a delay holds (see :class:`Execution`).
AROUND_DELAYS = ("wait", "reroute", "off")


@dataclass
class ExecutionMeasures:
    """Counts since the start, over every robot and tick (robot-ticks)."""

    ticks: int = 0
    robot_ticks: int = 0
    #: Had a move to make and stood still, delayed.
    own_delay: int = 0
    #: Had a move to make, was neither delayed nor held, and stood still: a robot ahead
    #: had not moved on (knock-on delay).
    knock_on: int = 0
    #: Had a move to make and stood still, held by the caller (and not delayed).
    held: int = 0
    #: Delayed, whether or not it had a move to make.
    delayed: int = 0
    #: Ticks behind the plan, summed over robots and ticks.
    drift: int = 0
    #: Windows planned.
    plans: int = 0

    def shares(self) -> dict[str, float]:
        """The shares of robot-ticks (and the mean drift in ticks), for reports."""
        total = max(self.robot_ticks, 1)
        return {
            "own_delay_share": self.own_delay / total,
            "knock_on_share": self.knock_on / total,
            "held_share": self.held / total,
            "delayed_share": self.delayed / total,
            "mean_drift_ticks": self.drift / total,
        }


class TickOutcome(NamedTuple):
    """One tick: the executor's report, and which robots were delayed and held."""

    report: TickReport
    delayed: np.ndarray
    held: np.ndarray


class Execution:
    """Plans executed asynchronously on a floor: see the module.

    Args:
        grid: The floor.
        cells: ``(N, 2)`` each robot's ``(row, col)`` at rest; distinct free cells.
        ticks_per_move: Ticks one move takes (LoRR's ``agentCounter``), 1 to
            :data:`~warehouse_phys.execution.ticks.MAX_TICKS_PER_MOVE`; 1 with no delays is
            lock step.
        speeds: ``(N,)`` per-robot speed factors
            (:func:`~warehouse_phys.execution.ticks.move_ticks`), ``None`` for all 1.
        delays: LoRR's ``delayConfig``, delays replayed from a run
            (:class:`~warehouse_phys.execution.delay_replay.DelayReplay`, one robot a row
            of this fleet), or ``None`` for no delays.
        plan_every: Ticks between plans (default: ``ticks_per_move``, one move's time).
        window: Steps in each planned window, 1 to :data:`MAX_WINDOW`.
        planner: The planner of the windows, or its name in
            :data:`~warehouse_phys.execution.windows.WINDOW_PLANNERS` (built for the
            robots' moves and ``seed``); default ``PIBT(grid, seed=seed)``, with corner
            follows. Its rotations are broken
            (:func:`~warehouse_phys.execution.windows.pibt_window`) unless every robot's
            moves take the same ticks and ``min_gap`` allows them, as the executor
            requires.
        guidance: A planner named ``planner``: its guided planner's fields
            (:func:`~warehouse_phys.execution.windows.window_planner`; None: its own).
        min_gap: The executor's closest approach of two centres [cells].
        around_delays: How the windows treat robots that a delay will still hold at the
            next tick: ``"wait"`` (default) plans them to wait, first (PIBT
            ``requests``), so that the others do not count on them moving; ``"reroute"``
            also makes them obstacles of the distances the others follow (PIBT's
            ``movable``: the others plan round them rather than queue behind them; the
            distance maps are rebuilt whenever the set of such robots changes, which
            costs a search a goal: for small fleets); ``"off"`` plans them as any other.
        headings: ``(N,)`` turning robots' headings (LoRR's robots: a forward move or a
            quarter turn each takes the ticks of a move); the default planner is then
            ``PIBT(grid, moves="rotate")``. ``None``: four-direction robots.
        seed: The default planner's seed.

    Raises:
        ValueError, TypeError: naming the argument, as the parts check them.
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        cells: ArrayLike,
        *,
        ticks_per_move: int = 1,
        speeds: ArrayLike | None = None,
        delays: DelayConfig | None = None,
        plan_every: int | None = None,
        window: int = 1,
        planner: PIBT | GuidedPIBT | str | None = None,
        guidance: Mapping[str, Any] | None = None,
        min_gap: float = DEFAULT_MIN_GAP,
        around_delays: str = "wait",
        headings: ArrayLike | None = None,
        seed: int = 0,
    ) -> None:
        cells = np.asarray(cells)
        ticks_per_move = check_ticks_per_move(ticks_per_move)
        n = len(cells)
        needed = move_ticks(ticks_per_move, n, speeds)
        self.grid = grid
        self.executor = Executor(
            grid, cells, needed, min_gap, None if headings is None else np.asarray(headings)
        )
        self.ticks_per_move = ticks_per_move
        self.plan_every = check_whole(
            "plan_every", ticks_per_move if plan_every is None else plan_every, 1, 10**9
        )
        self.window = check_whole("window", window, 1, MAX_WINDOW)
        if delays is not None and not isinstance(delays, (DelayConfig, DelayReplay)):
            raise TypeError(f"delays must be a DelayConfig, a DelayReplay or None, got "
                            f"{type(delays).__name__}")  # fmt: skip
        if isinstance(delays, DelayReplay) and delays.n_robots != n:
            raise ValueError(f"delays replay {delays.n_robots} robots, the fleet has {n}")
        self.delays = delays if isinstance(delays, DelayReplay) else (
            None if delays is None else DelayGenerator(delays, n)
        )  # fmt: skip
        #: Whether the windows may hold rotations (else they are broken).
        self.rotations = bool((needed == needed[:1]).all()) and (
            self.executor.min_gap <= DEFAULT_MIN_GAP
        )
        moves = "grid" if headings is None else "rotate"
        if isinstance(planner, str):
            planner = window_planner(planner, grid, moves=moves, seed=seed, **(guidance or {}))
        elif guidance:
            raise ValueError("guidance sets the fields of a planner given by its name")
        self.planner = planner or PIBT(grid, moves=moves, seed=seed)
        if around_delays not in AROUND_DELAYS:
            raise ValueError(
                f"around_delays must be one of {', '.join(AROUND_DELAYS)}, got {around_delays!r}"
            )
        self.around_delays = around_delays
        self.measures = ExecutionMeasures()

    @property
    def tick_number(self) -> int:
        """Ticks executed so far."""
        return self.executor.tick

    def tick(self, goals: ArrayLike, hold: ArrayLike | None = None) -> TickOutcome:
        """Run one tick towards ``goals`` (``(N, 2)`` cells; a robot's own cell for none):
        plan if it is time to, draw the delays, hold the robots ``hold`` (``(N,)`` bool,
        none by default) and step the executor."""
        executor = self.executor
        n = len(executor.left)
        if executor.tick % self.plan_every == 0:
            options: dict[str, object] = {}
            if self.delays is not None and self.around_delays != "off":
                stuck = self.delays.remaining > 1
                if self.around_delays == "reroute":
                    options["movable"] = ~stuck
                else:
                    wait = WAIT if executor.headings is None else TurnAction.WAIT
                    options["requests"] = dict.fromkeys(np.flatnonzero(stuck).tolist(), wait)
            path = pibt_window(self.planner, executor.plan_cells(), np.asarray(goals),
                               self.window, headings=executor.plan_headings(),
                               rotations=self.rotations, **options)  # fmt: skip
            executor.add_plan(path)
            self.measures.plans += 1
        delayed = self.delays.next_tick() if self.delays else np.zeros(n, dtype=bool)
        held = np.zeros(n, dtype=bool) if hold is None else _checked_hold(hold, n)
        report = executor.step(delayed | held)
        self._count(report, delayed, held)
        return TickOutcome(report, delayed, held)

    def _count(self, report: TickReport, delayed: np.ndarray, held: np.ndarray) -> None:
        stood = report.own_delay  # had a move, stood still, delayed or held
        measures = self.measures
        measures.ticks += 1
        measures.robot_ticks += len(delayed)
        measures.own_delay += int(np.count_nonzero(stood & delayed))
        measures.held += int(np.count_nonzero(stood & held & ~delayed))
        measures.knock_on += int(np.count_nonzero(report.knock_on))
        measures.delayed += int(np.count_nonzero(delayed))
        measures.drift += int(self.executor.drift().sum())


def _checked_hold(hold: ArrayLike, n: int) -> np.ndarray:
    held = np.asarray(hold)
    if held.shape != (n,) or held.dtype != bool:
        raise ValueError(f"hold must be ({n},) bool, got {held.dtype} {held.shape}")
    return held
